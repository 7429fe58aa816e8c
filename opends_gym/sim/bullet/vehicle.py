"""`physics="bullet"`: the ego car as a pybullet rigid body on a raycast-vehicle suspension.

Why: OpenDS drives a Bullet raycast vehicle (jME `VehicleControl`): a rigid chassis whose
four wheels are rays with spring-damper suspension and friction-limited tyres. This backend
rebuilds that model on pybullet, so the car pitches, rolls, climbs terrain and pushes or
stops at solid scene objects, while taking the same steer angle and powertrain forces as
`physics="fast"` (the `VehicleBackend` protocol).

The wheels (`bullet/wheels.py`) map OpenDS's suspension and tyre parameters; the
chassis is a box from 0.25 m above the road to the car's height, with the yaw inertia of
`VehicleSpec` (as the fast backend). `BodyState.y` is the ground level under the centre of
gravity (its height minus `cog_height_m`), like the fast backend's. Euler angles are jME's
(pitch about X, yaw about Y, roll about Z; positive pitch raises the nose, positive roll
lowers the left side).

Determinism: one private DIRECT client per instance, a fixed time step, sorted overlapping
pairs, no randomness. `get_state()` serialises the whole Bullet world (contact caches
included) and `set_state()` rebuilds the world and restores it, so a restored run replays
bit for bit, in this World or another built from the same task. A full reset rebuilds the
world too, so every episode starts like a fresh World.
"""

from __future__ import annotations

import contextlib
import math
import shutil
import tempfile
import weakref
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pybullet as pb
from pybullet_utils import bullet_client

from ...task.model_task import DrivingTask
from ...task.values import yaw_from_quat
from ..ego.spec import BodyState, VehicleSpec
from ..geometry2d import Obb
from ..scene_objects import SceneObjects
from .scene import G_CAR, MASK_CAR, RAY_MASK, Placement, SceneBuilder, quat_mul, yaw_quat
from .wheels import RaycastWheels

CHASSIS_CLEARANCE_M = 0.25
MOVED_M = 1e-3  # a pushed scene model's pose is written back once it moved this far
TWO_PI = 2.0 * math.pi
RESTORES_PER_CLIENT = 200  # set_state calls before the client is renewed (bounds pybullet's file cache)


def _cleanup(client: bullet_client.BulletClient, folder: str) -> None:
    with contextlib.suppress(pb.error):
        client.disconnect()
    if folder:
        shutil.rmtree(folder, ignore_errors=True)


class BulletVehicle:
    """The ego car and its world in one private pybullet client. See the module docstring."""

    def __init__(
        self,
        spec: VehicleSpec,
        task: DrivingTask,
        objects: SceneObjects | None = None,
        ground_height: float | Callable[[float, float], float] | None = None,
    ) -> None:
        """`objects`: the World's scene models (None: this backend's own copy, reset on every reset).

        `ground_height`: the flat ground's height; a callable (x, z) -> y, as the fast backend
        takes, is read at the start position. Default: the start pose's height. A terrain
        height map in the scene replaces the flat ground.
        """
        self.spec = spec
        self.state = BodyState()
        self.task = task
        self._client = bullet_client.BulletClient(connection_mode=pb.DIRECT)
        self._cid = int(self._client._client)
        self._folder = tempfile.mkdtemp(prefix="opends_bullet_")
        self._finalizer = weakref.finalize(self, _cleanup, self._client, self._folder)
        self._owns_objects = objects is None
        self.objects = objects if objects is not None else SceneObjects(task)
        self._objects_generation = self.objects.generation
        start = task.start_pose.position_m
        if callable(ground_height):
            ground_y = float(ground_height(start[0], start[2]))
        else:
            ground_y = float(ground_height) if ground_height is not None else float(start[1])
        self._gravity = task.scene.gravity_mps2 if task.scene.gravity_mps2 > 0.0 else 9.81
        self.scene = SceneBuilder(self._cid, task, self.objects, ground_y)
        self._initial = {k: self.scene.placement_of(k) for k in self.scene.physical}
        self._simulated = {self.objects.objects[k].index for k in self.scene.physical}  # scene model indices
        self._dt = 1.0 / 60.0
        self._restores = 0
        self._yaw = task.start_pose.yaw_rad
        self.wheels = RaycastWheels(spec, self._gravity)
        w = self.wheels
        self.state.extra = {"suspension_m": w.suspension_m, "wheel_load_n": w.load_n, "wheel_spin_rad": w.spin_rad}
        self._build(self._initial)
        self.reset(start[0], start[1], start[2], task.start_pose.yaw_rad, 0.0)

    @property
    def client_id(self) -> int:
        """The private pybullet client (e.g. for camera images of this World)."""
        return self._cid

    @property
    def warnings(self) -> list[str]:
        """Stand-in boxes and unreadable terrain images, one message per model key."""
        return self.scene.warnings

    # ------------------------------------------------------------------ construction
    def _build(self, placements: dict[int, Placement]) -> None:
        """A fresh Bullet world: ground, scene bodies in index order, then the car."""
        cid = self._cid
        pb.resetSimulation(physicsClientId=cid)
        pb.setGravity(0.0, -self._gravity, 0.0, physicsClientId=cid)
        pb.setPhysicsEngineParameter(fixedTimeStep=self._dt, numSubSteps=0, deterministicOverlappingPairs=1, physicsClientId=cid)
        self._ground, self._bodies = self.scene.build(placements)
        self._dynamic = [sb for sb in self._bodies if sb.dynamic]
        self._placed = dict(placements)
        spec = self.spec
        h = spec.cog_height_m
        height = max(0.3, spec.height_m - CHASSIS_CLEARANCE_M)
        centre = (0.0, CHASSIS_CLEARANCE_M + 0.5 * height - h, -(0.5 * spec.wheelbase_m - spec.cog_to_front_m))
        shape = pb.createCollisionShape(
            pb.GEOM_BOX,
            halfExtents=[0.5 * spec.width_m, 0.5 * height, 0.5 * spec.length_m],
            collisionFramePosition=centre,
            physicsClientId=cid,
        )
        start = self.task.start_pose
        x, y, z = start.position_m
        self._car = pb.createMultiBody(
            spec.mass_kg, shape, basePosition=[x, y + h, z], baseOrientation=yaw_quat(start.yaw_rad), physicsClientId=cid
        )
        m, L, W, H = spec.mass_kg, spec.length_m, spec.width_m, spec.height_m
        pb.changeDynamics(
            self._car,
            -1,
            localInertiaDiagonal=[m * (H * H + L * L) / 12.0, spec.yaw_inertia, m * (H * H + W * W) / 12.0],
            linearDamping=0.0,
            angularDamping=0.0,
            lateralFriction=0.6,
            activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING,
            physicsClientId=cid,
        )
        pb.setCollisionFilterGroupMask(self._car, -1, G_CAR, MASK_CAR, physicsClientId=cid)
        self._dirty = False
        self._read()

    # ------------------------------------------------------------------ lifecycle
    def reset(self, x: float, y: float, z: float, yaw: float, speed_mps: float) -> None:
        """A World reset (its scene objects were reset) restarts the whole world; else a teleport."""
        if self._owns_objects or self.objects.generation != self._objects_generation:
            if self._owns_objects:
                self.objects.reset()
            self._objects_generation = self.objects.generation
            if self._dirty or self._placed != self._initial:
                self._build(self._initial)
        cid = self._cid
        hit = pb.rayTestBatch([(x, y + 3.0, z)], [(x, y - 100.0, z)], numThreads=1, collisionFilterMask=RAY_MASK, physicsClientId=cid)[0]
        ground = hit[3][1] if hit[0] >= 0 else y
        pb.resetBasePositionAndOrientation(self._car, (x, ground + self.spec.cog_height_m, z), yaw_quat(yaw), physicsClientId=cid)
        pb.resetBaseVelocity(self._car, (-math.sin(yaw) * speed_mps, 0.0, -math.cos(yaw) * speed_mps), (0.0, 0.0, 0.0), physicsClientId=cid)
        self._yaw = yaw
        self.state.steer_rad = 0.0
        self.wheels.reset()
        self._read()

    def close(self) -> None:
        """Disconnect the private client (idempotent)."""
        self._finalizer()

    # ------------------------------------------------------------------ stepping
    def step(self, dt_s: float, steer_rad: float, drive_force_n: float, brake_force_n: float, side_force_n: float = 0.0) -> None:
        cid = self._cid
        if dt_s != self._dt:
            self._dt = dt_s
            pb.setPhysicsEngineParameter(fixedTimeStep=dt_s, physicsClientId=cid)
        if self._bodies:
            self._sync_objects()
        wheels = self.wheels
        froms, tos = wheels.rays(self._pos, self._rot)
        hits = pb.rayTestBatch(froms, tos, numThreads=1, collisionFilterMask=RAY_MASK, physicsClientId=cid)
        (fx_t, fy_t, fz_t), torque = wheels.forces(
            hits, self._pos, self._rot, self._lin, self._ang, steer_rad, drive_force_n, brake_force_n, dt_s
        )
        if side_force_n:
            yaw = self._yaw
            fx_t -= math.cos(yaw) * side_force_n
            fz_t += math.sin(yaw) * side_force_n
        car = self._car
        pb.applyExternalForce(car, -1, (fx_t, fy_t, fz_t), self._pos, pb.WORLD_FRAME, physicsClientId=cid)
        pb.applyExternalTorque(car, -1, torque, pb.WORLD_FRAME, physicsClientId=cid)
        pb.stepSimulation(physicsClientId=cid)
        self._dirty = True
        self.state.steer_rad = steer_rad
        self._read()
        if self._dynamic:
            self._write_back()

    def stop_at_contact(self, x: float, z: float) -> None:
        """Bullet resolves contacts with its bodies itself; this only covers obstacles it has none for.

        Every model that is collidable at the start, or that a `manipulateObject` action may make
        collidable, is a solid body: the contact stops or deflects the car, and it pushes dynamic models, so
        teleporting it back (the fast backend's response) would fight Bullet. A model made
        collidable by other code has no body; touching one stops the car as the fast backend does.
        """
        s = self.state
        spec = self.spec
        shift = 0.5 * spec.wheelbase_m - spec.cog_to_front_m
        car = Obb(s.x - shift * math.sin(s.yaw), s.z - shift * math.cos(s.yaw), s.yaw, 0.5 * spec.width_m, 0.5 * spec.length_m)
        _, obstacles = self.objects.overlapping(car, s.y - 0.5, s.y + spec.height_m)
        if all(o.index in self._simulated for o in obstacles):
            return
        cid = self._cid
        pb.resetBasePositionAndOrientation(self._car, (x, self._pos[1], z), self._orn, physicsClientId=cid)
        pb.resetBaseVelocity(self._car, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), physicsClientId=cid)
        self._read()

    def _read(self) -> None:
        """Pull the car's pose and velocities from Bullet into the cache and `state`."""
        cid = self._cid
        pos, orn = pb.getBasePositionAndOrientation(self._car, physicsClientId=cid)
        self._lin, self._ang = pb.getBaseVelocity(self._car, physicsClientId=cid)
        self._pos, self._orn = pos, orn
        qx, qy, qz, qw = orn
        xx, yy, zz, xy, xz, yz, wx, wy, wz = qx * qx, qy * qy, qz * qz, qx * qy, qx * qz, qy * qz, qw * qx, qw * qy, qw * qz
        r02, r12, r22 = 2.0 * (xz + wy), 2.0 * (yz - wx), 1.0 - 2.0 * (xx + yy)
        r10, r11 = 2.0 * (xy + wz), 1.0 - 2.0 * (xx + zz)
        self._rot = (1.0 - 2.0 * (yy + zz), 2.0 * (xy - wz), r02, r10, r11, r12, 2.0 * (xz - wy), 2.0 * (yz + wx), r22)
        raw = math.atan2(r02, r22)
        yaw = raw + TWO_PI * round((self._yaw - raw) / TWO_PI)  # continuous, like the fast backend's
        self._yaw = yaw
        s = self.state
        s.x, s.z = pos[0], pos[2]
        s.y = pos[1] - self.spec.cog_height_m
        s.yaw = yaw
        s.pitch = math.asin(max(-1.0, min(1.0, -r12)))
        s.roll = math.atan2(r10, r11)
        sy, cy = math.sin(yaw), math.cos(yaw)
        lx, _, lz = self._lin
        s.u = -lx * sy - lz * cy
        s.v = -lx * cy + lz * sy
        s.r = self._ang[1]

    # ------------------------------------------------------------------ scene models
    def _sync_objects(self) -> None:
        """Apply what actions changed on scene models (pose, scale, collidable) to their bodies."""
        objs = self.objects.objects
        placed = self._placed
        changed = []
        for sb in self._bodies:
            o = objs[sb.index]
            pl = placed[sb.index]
            if o.position is pl.position and o.scale is pl.scale and o.yaw == pl.yaw and o.collidable == pl.collidable:
                continue
            if o.position == pl.position and o.scale == pl.scale and o.yaw == pl.yaw and o.collidable == pl.collidable:
                continue
            changed.append(sb.index)
        if not changed:
            return
        if any(objs[i].scale != placed[i].scale for i in changed):
            # Bullet cannot rescale a shape: rebuild the world with the new sizes, keep its state
            data = self._save()
            rescaled = dict(placed)
            for i in changed:
                rescaled[i] = Placement(placed[i].position, placed[i].yaw, objs[i].scale, placed[i].collidable)
            self._build(rescaled)
            self._restore(data)
            self._dirty = True
            placed = self._placed
        by_index = {sb.index: sb for sb in self._bodies}
        cid = self._cid
        for i in changed:
            o, pl, sb = objs[i], placed[i], by_index[i]
            if o.position != pl.position or o.yaw != pl.yaw:
                orn = quat_mul(yaw_quat(o.yaw - sb.base_yaw), sb.base_quat)
                pb.resetBasePositionAndOrientation(sb.body, o.position, orn, physicsClientId=cid)
                if sb.dynamic:
                    pb.resetBaseVelocity(sb.body, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), physicsClientId=cid)
            if o.collidable != pl.collidable:
                self.scene.set_collidable(sb, o.collidable)
            placed[i] = Placement(o.position, o.yaw, o.scale, o.collidable)

    def _write_back(self) -> None:
        """Pushed models: their new pose goes to `SceneObjects` (collisions, triggers, recordings)."""
        objs = self.objects.objects
        cid = self._cid
        for sb in self._dynamic:
            pos, orn = pb.getBasePositionAndOrientation(sb.body, physicsClientId=cid)
            pl = self._placed[sb.index]
            yaw = yaw_from_quat(orn)
            ox, oy, oz = pl.position
            turned = abs(math.remainder(yaw - pl.yaw, TWO_PI))
            if abs(pos[0] - ox) < MOVED_M and abs(pos[1] - oy) < MOVED_M and abs(pos[2] - oz) < MOVED_M and turned < MOVED_M:
                continue
            o = objs[sb.index]
            o.position, o.yaw = (pos[0], pos[1], pos[2]), yaw
            self._placed[sb.index] = Placement(o.position, o.yaw, o.scale, o.collidable)
            self.objects.update(o)

    # ------------------------------------------------------------------ state
    def _reconnect(self) -> None:
        """A new client: pybullet keeps every state file it restored until its client closes."""
        self._finalizer.detach()
        _cleanup(self._client, "")
        self._client = bullet_client.BulletClient(connection_mode=pb.DIRECT)
        self._cid = self.scene.cid = int(self._client._client)
        self._finalizer = weakref.finalize(self, _cleanup, self._client, self._folder)
        self._restores = 0

    def _save(self) -> bytes:
        path = Path(self._folder) / "save.bullet"
        pb.saveBullet(str(path), physicsClientId=self._cid)
        return path.read_bytes()

    def _restore(self, data: bytes) -> None:
        # a fresh name each time: pybullet caches what it read under a file name
        self._restores += 1
        path = Path(self._folder) / f"restore{self._restores}.bullet"
        path.write_bytes(data)
        pb.restoreState(fileName=str(path), physicsClientId=self._cid)
        path.unlink()

    def get_state(self) -> dict[str, Any]:
        """Every body's pose and velocities (Bullet's own serialisation), suspension and wheels."""
        s = self.state
        return {
            "bullet": self._save(),
            "placed": dict(self._placed),
            "dt": self._dt,
            "yaw": self._yaw,
            "steer": s.steer_rad,
            "wheels": self.wheels.get_state(),
            "pose": (s.x, s.y, s.z, s.yaw, s.pitch, s.roll),
            "vel": (s.u, s.v, s.r),
        }

    def set_state(self, state: dict[str, Any]) -> None:
        """Rebuild the world (fresh contact caches) and restore a `get_state()`."""
        if self._restores >= RESTORES_PER_CLIENT:
            self._reconnect()
        self._dt = float(state["dt"])
        self._build(dict(state["placed"]))
        self._restore(state["bullet"])
        self._dirty = True
        self._yaw = float(state["yaw"])
        self.state.steer_rad = float(state["steer"])
        self.wheels.set_state(state["wheels"])
        self._read()

"""Vectors, rotations and colours as OpenDS writes them (`<vector><entry>..`).

Why: OpenDS stores every position, rotation, scale and colour as a `vector` of `entry`
elements, and rotations as Euler degrees in jME's convention or as a quaternion. These
codecs turn them into plain tuples (metres) and a `Rotation` (quaternion, radians).

World frame (as in OpenDS/jME): metres, Y up. A car with the identity rotation faces -Z;
a positive yaw turns it to the left (towards -X).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from lxml import etree

from .bind import FLOAT, Custom, ReadCtx, WriteCtx, children, parse_scalar
from .xmlsafe import local_name

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]  # x, y, z, w (jME order)


def _read_vector(el: etree._Element, ctx: ReadCtx, size: int | None) -> tuple[float, ...]:
    vec = children(el, "vector")
    holder = vec[0] if vec else el
    entries = children(holder, "entry")
    values = tuple(parse_scalar(FLOAT, e.text or "", e, ctx, f"{local_name(el)} entry") for e in entries)
    if size is not None and len(values) != size:
        raise ctx.error(f"<{local_name(el)}> needs {size} entries, found {len(values)}", holder if vec else el)
    declared = holder.get("size")
    if vec and declared is not None and declared.strip().isdigit() and int(declared) != len(values):
        ctx.warn(f"vector declares size={declared} but has {len(values)} entries", holder)
    return values


def _write_vector(el: etree._Element, values: tuple[float, ...], ctx: WriteCtx) -> None:
    vec = ctx.sub(el, "vector")
    vec.set("jtype", "java_lang_Float")
    vec.set("size", str(len(values)))
    for v in values:
        ctx.sub(vec, "entry").text = repr(float(v))


def vector(size: int | None) -> Custom[tuple[float, ...]]:
    """Codec for an element holding `<vector>` with `size` entries (None: any number)."""
    return Custom(lambda el, ctx: _read_vector(el, ctx, size), _write_vector)


VEC3 = vector(3)
COLOR = vector(4)
FLOATS = vector(None)


def euler_deg_to_quat(x_deg: float, y_deg: float, z_deg: float) -> Quat:
    """jME `Quaternion.fromAngles(x, y, z)` (angles in degrees)."""
    ax, ay, az = (math.radians(v) * 0.5 for v in (x_deg, y_deg, z_deg))
    sx, cx = math.sin(ax), math.cos(ax)
    sy, cy = math.sin(ay), math.cos(ay)
    sz, cz = math.sin(az), math.cos(az)
    cycz, sysz, cysz, sycz = cy * cz, sy * sz, cy * sz, sy * cz
    w = cycz * cx - sysz * sx
    x = cycz * sx + sysz * cx
    y = sycz * cx + cysz * sx
    z = cysz * cx - sycz * sx
    n = math.sqrt(w * w + x * x + y * y + z * z) or 1.0
    return (x / n, y / n, z / n, w / n)


def quat_rotate(q: Quat, v: Vec3) -> Vec3:
    """Rotate vector `v` by unit quaternion `q`."""
    x, y, z, w = q
    vx, vy, vz = v
    # t = 2 * cross(q.xyz, v); v' = v + w t + cross(q.xyz, t)
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (
        vx + w * tx + (y * tz - z * ty),
        vy + w * ty + (z * tx - x * tz),
        vz + w * tz + (x * ty - y * tx),
    )


def yaw_from_quat(q: Quat) -> float:
    """Heading (rad) about +Y of the rotated forward axis (-Z); 0 = facing -Z, + = left."""
    fx, _, fz = quat_rotate(q, (0.0, 0.0, -1.0))
    return math.atan2(-fx, -fz)


def quat_to_angles(q: Quat) -> Vec3:
    """jME `Quaternion.toAngles`: (x, y, z) Euler angles in radians."""
    x, y, z, w = q
    sqw, sqx, sqy, sqz = w * w, x * x, y * y, z * z
    unit = sqx + sqy + sqz + sqw
    test = x * y + z * w
    if test > 0.499 * unit:
        return (0.0, 2.0 * math.atan2(x, w), 0.5 * math.pi)
    if test < -0.499 * unit:
        return (0.0, -2.0 * math.atan2(x, w), -0.5 * math.pi)
    return (
        math.atan2(2 * x * w - 2 * y * z, -sqx + sqy - sqz + sqw),
        math.atan2(2 * y * w - 2 * x * z, sqx - sqy - sqz + sqw),
        math.asin(max(-1.0, min(1.0, 2 * test / unit))),
    )


def car_rotation(rot: Rotation) -> Rotation:
    """The rotation OpenDS gives a car placed with `rot`: `Car.setRotation` negates the
    heading angle ("compensate that car is actually driving backwards"), so a scene car
    rotated by +132 deg about Y drives at heading -132 deg (the real Countryside drive logs
    start at the quaternion of -132 deg)."""
    ax, ay, az = quat_to_angles(rot.quaternion)
    return Rotation.from_euler_deg(math.degrees(ax), -math.degrees(ay), math.degrees(az))


def quat_from_yaw(yaw: float) -> Quat:
    return (0.0, math.sin(yaw * 0.5), 0.0, math.cos(yaw * 0.5))


@dataclass(frozen=True)
class Rotation:
    """An orientation. `quaternion` is authoritative; `euler_deg` keeps the file's form."""

    quaternion: Quat = (0.0, 0.0, 0.0, 1.0)
    euler_deg: Vec3 | None = None

    @staticmethod
    def from_euler_deg(x: float, y: float, z: float) -> Rotation:
        return Rotation(euler_deg_to_quat(x, y, z), (x, y, z))

    @property
    def yaw_rad(self) -> float:
        return yaw_from_quat(self.quaternion)


IDENTITY = Rotation()


def _read_rotation(el: etree._Element, ctx: ReadCtx) -> Rotation:
    flag = (el.get("quaternion") or "false").strip().lower()
    if flag not in ("true", "false", "1", "0"):
        raise ctx.error(f"'{flag}' is not a valid boolean for attribute 'quaternion'", el)
    if flag in ("true", "1"):
        values = _read_vector(el, ctx, None)
        if len(values) == 3:
            ctx.warn('quaternion="true" with 3 entries; read as Euler angles in degrees', el)
            return Rotation.from_euler_deg(*values)
        if len(values) != 4:
            raise ctx.error(f"<rotation> quaternion needs 4 entries, found {len(values)}", el)
        x, y, z, w = values
        n = math.sqrt(x * x + y * y + z * z + w * w)
        if n == 0.0:
            raise ctx.error("quaternion has zero length", el)
        return Rotation((x, y, z, w))
    ex, ey, ez = _read_vector(el, ctx, 3)
    return Rotation.from_euler_deg(ex, ey, ez)


def _write_rotation(el: etree._Element, value: Rotation, ctx: WriteCtx) -> None:
    if value.euler_deg is not None:
        el.set("quaternion", "false")
        _write_vector(el, value.euler_deg, ctx)
    else:
        el.set("quaternion", "true")
        _write_vector(el, value.quaternion, ctx)


ROTATION = Custom(_read_rotation, _write_rotation)

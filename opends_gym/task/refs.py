"""Cross-file checks: every `ref` names something, ids that are referenced are unique.

Why: OpenDS discovers a dangling reference only when the simulation reaches it (a
trigger that never fires, a car that does not move). We check every reference at load
and name the file and line of the element that refers to nothing.

Rules: a reference to nothing is a `TaskError`; so is a duplicate id among things that
are looked up by id (sounds, geometries, reset points, activities, lanes, segments,
traffic...). Scene models may repeat ids (real tasks tile 2500 road pieces under one id)
unless something refers to that id. Duplicate trigger ids occur in real tasks and only
warn. Missing asset files only warn, as in OpenDS.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable
from pathlib import Path

from .actions_catalog import action_spec
from .bind import parse_scalar
from .errors import Diagnostics, TaskError
from .model_interaction import Interaction
from .model_scenario import Scenario
from .model_scene import Model, Point, Scene
from .model_taskxml import TaskSpec
from .model_traffic import Pedestrian, TrafficVehicle, VehicleWayPoint


class RefChecker:
    """Checks one loaded task; `files` maps layer name to the file it came from."""

    def __init__(self, files: dict[str, Path], diag: Diagnostics) -> None:
        self.files = files
        self.diag = diag

    # ------------------------------------------------------------------ helpers
    def _err(self, layer: str, line: int, element: str, message: str) -> TaskError:
        return TaskError(message, file=self.files.get(layer), line=line or None, element=element)

    def _unique(self, layer: str, element: str, items: Iterable[tuple[str, int]]) -> set[str]:
        seen: dict[str, int] = {}
        for ident, line in items:
            if not ident:
                continue
            if ident in seen:
                raise self._err(layer, line, element, f"duplicate id '{ident}' (first declared on line {seen[ident]})")
            seen[ident] = line
        return set(seen)

    def _need(self, ok: bool, layer: str, line: int, element: str, what: str, name: str, soft: str = "") -> None:
        """Fail unless `ok`; with `soft` (the consequence), only warn, as OpenDS runs on."""
        if ok:
            return
        if soft:
            self.diag.warn(
                f"{what} '{name}' names nothing; {soft}", self.files.get(layer), line or None, element, once_key=f"ref:{what}:{name}"
            )
            return
        raise self._err(layer, line, element, f"{what} '{name}' names nothing")

    # ------------------------------------------------------------------ entry
    def check(self, scene: Scene, scenario: Scenario, interaction: Interaction, task: TaskSpec | None) -> None:
        model_counts = Counter(m.id for m in scene.models if m.id)
        model_lines = {m.id: m.line for m in reversed(scene.models)}
        self.models = set(model_counts)
        self.model_counts = model_counts
        self.model_lines = model_lines
        self.sounds = self._unique("scene", "sound", ((s.id, s.line) for s in scene.sounds))
        self.movies = self._unique("scene", "movie", ((m.id, m.line) for m in scene.movies))
        self.pictures = self._unique("scene", "picture", ((p.id, p.line) for p in scene.pictures))
        self.geometries = self._unique("scene", "geometries", ((g.id, g.line) for g in scene.geometries))
        self.points = {g.id for g in scene.geometries if isinstance(g, Point)}
        self.reset_points = self._unique("scene", "resetPoint", ((r.id, r.line) for r in scene.reset_points))
        self._check_scene(scene)
        self._check_scenario(scenario)
        self._check_interaction(interaction, scenario)
        if task is not None:
            self._check_task(task, scenario)

    def _model_ref(self, model_id: str, layer: str, line: int, element: str, what: str) -> None:
        self._need(model_id in self.models, layer, line, element, what, model_id)
        if self.model_counts[model_id] > 1:
            raise self._err(
                layer,
                line,
                element,
                f"{what} '{model_id}' is ambiguous: {self.model_counts[model_id]} scene models share this id "
                f"(first on {self.files['scene'].name} line {self.model_lines[model_id]})",
            )

    # ------------------------------------------------------------------ scene
    def _check_scene(self, scene: Scene) -> None:
        for m in scene.models:
            self._check_model(m)
        for s in scene.sounds:
            if s.positional and s.positional.parent_node and s.positional.parent_node.model_node:
                ref = s.positional.parent_node.model_node
                self._need(ref in self.models, "scene", s.line, "modelNode", "sound parent model", ref)

    def _check_model(self, m: Model) -> None:
        if m.ref:
            self._need(m.ref in self.geometries, "scene", m.line, "model", f"model '{m.id}' geometry ref", m.ref)
        if not m.key and not m.ref:
            raise self._err("scene", m.line, "model", f"model '{m.id}' needs a key (asset) or a ref (geometry)")
        if m.translation_m is None and m.open_drive_position is None:
            raise self._err("scene", m.line, "model", f"model '{m.id}' needs <translation> or <openDrivePosition>")
        if m.collision_sound_ref:
            self._need(m.collision_sound_ref in self.sounds, "scene", m.line, "collisionSound", "collision sound", m.collision_sound_ref)

    # ------------------------------------------------------------------ scenario
    def _point_ref(self, ref: str, line: int, element: str) -> None:
        self._need(ref in self.points, "scenario", line, element, f"{element} ref (a scene <point>)", ref)

    def _check_scenario(self, sc: Scenario) -> None:
        car = sc.driver.car
        self.car_resets = {rp.ref or rp.id for rp in car.reset_points}
        self._model_ref(car.ref, "scenario", car.line, "car", "car ref (a scene model)")
        for rp in car.reset_points:
            if rp.ref:
                self._need(rp.ref in self.reset_points, "scenario", rp.line, "resetPoint", "reset point ref", rp.ref, soft="it is left out")
            elif rp.translation_m is None:
                raise self._err("scenario", rp.line, "resetPoint", "reset point needs a ref or a <translation>")
        self._unique("scenario", "idealTrack", ((t.id, t.line) for t in sc.driver.ideal_tracks))
        for track in sc.driver.ideal_tracks:
            if len(track.points) < 2:
                raise self._err("scenario", track.line, "idealTrack", f"ideal track '{track.id}' needs at least 2 points")
            for p in track.points:
                self._track_point(p.ref, p.translation_m is not None, p.line)
        if sc.driver.camera_flight is not None:
            for p in sc.driver.camera_flight.track:
                self._track_point(p.ref, p.translation_m is not None, p.line)
        road = sc.road
        self.lanes = self._unique("scenario", "lane", ((lane.id, lane.line) for lane in road.lanes))
        for lane in road.lanes:
            if lane.x_max_m <= lane.x_min_m:
                raise self._err("scenario", lane.line, "lane", f"lane '{lane.id}': xMax must be greater than xMin")
        inter_ids = Counter(i.id for i in road.intersections)
        for iid, n in inter_ids.items():
            if n > 1:
                line = next(i.line for i in road.intersections if i.id == iid)
                self.diag.warn(
                    f"intersection id '{iid}' is used {n} times (nothing refers to it; tolerated)",
                    self.files["scenario"],
                    line,
                    "intersection",
                )
        self.lights = self._unique("scenario", "trafficLight", ((tl.id, tl.line) for i in road.intersections for tl in i.traffic_lights))
        for inter in road.intersections:
            for tl in inter.traffic_lights:
                for name, ref in (("trigger", tl.trigger), ("phaseTrigger", tl.phase_trigger)):
                    if ref:
                        self._need(ref in self.models, "scenario", tl.line, "trafficLight", f"traffic light {name}", ref)
        for rs in road.road_signs:
            if rs.ref:
                self._need(rs.ref in self.models, "scenario", rs.line, "roadsign", "road sign ref", rs.ref)
        for sl in road.speed_limits:
            if sl.ref:
                self._need(sl.ref in self.models, "scenario", sl.line, "speedLimit", "speed limit ref", sl.ref)
        self._check_network(sc)
        self.traffic = self._unique("scenario", "traffic", ((t.id, t.line) for t in sc.traffic))
        for t in sc.traffic:
            if isinstance(t, (TrafficVehicle, Pedestrian)):
                self._check_path(t)
        for fi in sc.friction_map:
            if fi.geometry:
                self._need(
                    fi.geometry in self.geometries or fi.geometry in self.models,
                    "scenario",
                    fi.line,
                    "frictionItem",
                    "friction map geometry",
                    fi.geometry,
                )

    def _track_point(self, ref: str, inline: bool, line: int) -> None:
        if ref:
            self._point_ref(ref, line, "point")
        elif not inline:
            raise self._err("scenario", line, "point", "point needs a ref or a <translation>")

    def _check_network(self, sc: Scenario) -> None:
        road = sc.road
        wps = road.way_points.points if road.way_points else ()
        self.road_wps = self._unique("scenario", "wayPoint", ((w.key, w.line) for w in wps))
        for w in wps:
            if w.ref and w.translation_m is None:
                self._point_ref(w.ref, w.line, "wayPoint")
            elif not w.ref and w.translation_m is None:
                raise self._err("scenario", w.line, "wayPoint", f"waypoint '{w.id}' needs a ref or a <translation>")
            if w.traffic_light:
                self._need(w.traffic_light in self.lights, "scenario", w.line, "trafficLight", "waypoint traffic light", w.traffic_light)
        segs = road.segments.items if road.segments else ()
        self.segments = self._unique("scenario", "segment", ((s.id, s.line) for s in segs))
        for s in segs:
            for wp in (s.from_wp, s.to_wp, *s.via):
                self._need(wp in self.road_wps, "scenario", s.line, "segment", f"segment '{s.id}' waypoint", wp)
            for name, ref in (("leftNeighbor", s.left_neighbor), ("rightNeighbor", s.right_neighbor), ("giveWayTo", s.give_way_to)):
                if ref:
                    for part in ref.split(","):
                        if part.strip():
                            self._need(part.strip() in self.segments, "scenario", s.line, name, f"segment '{s.id}' {name}", part.strip())
        ap = sc.driver.car.auto_pilot
        if ap is not None:
            for ref in ap.segment_refs:
                self._need(ref in self.segments, "scenario", sc.driver.car.line, "segment", "autopilot segment", ref)
            if ap.way_points:  # Gen A 4.x: the autopilot's own waypoints, checked like a traffic car's
                self._check_own_waypoints(ap.way_points, "the driver's autopilot", ap.start_way_point, sc.driver.car.line)
            elif ap.start_way_point:
                self._need(
                    ap.start_way_point in self.road_wps,
                    "scenario",
                    sc.driver.car.line,
                    "startWayPoint",
                    "autopilot start waypoint",
                    ap.start_way_point,
                )

    def _check_own_waypoints(self, points: tuple[VehicleWayPoint, ...], owner: str, start: str | None, line: int) -> None:
        """A Gen A waypoint list: unique ids, a position each, known lights, a start among them."""
        own = self._unique("scenario", "wayPoint", ((w.id, w.line) for w in points))
        for w in points:
            if w.translation_m is None:
                if not w.ref:
                    raise self._err("scenario", w.line, "wayPoint", f"waypoint '{w.id}' of {owner} needs a ref or a <translation>")
                self._point_ref(w.ref, w.line, "wayPoint")
            if w.traffic_light:
                self._need(w.traffic_light in self.lights, "scenario", w.line, "trafficLight", "waypoint traffic light", w.traffic_light)
        if start:
            self._need(start in own, "scenario", line, "startWayPoint", f"start waypoint of {owner}", start)

    def _check_path(self, t: TrafficVehicle | Pedestrian) -> None:
        if t.way_points:
            self._check_own_waypoints(t.way_points, f"'{t.id}'", t.start_way_point, t.line)
            return
        for ref in t.segment_refs:
            self._need(ref in self.segments, "scenario", t.line, "segment", f"segment of '{t.id}'", ref)
        if not t.start_way_point:
            raise self._err(
                "scenario", t.line, type(t).__name__.lower(), f"'{t.id}' has neither <wayPoints> nor a <startWayPoint> on the road network"
            )
        self._need(
            t.start_way_point in self.road_wps, "scenario", t.line, "startWayPoint", f"start waypoint of '{t.id}'", t.start_way_point
        )

    # ------------------------------------------------------------------ interaction
    def _check_interaction(self, inter: Interaction, sc: Scenario) -> None:
        from .conditions import CollideWith

        activities = self._unique("interaction", "activity", ((a.id, a.line) for a in inter.activities))
        trig_counts = Counter(t.id for t in inter.triggers if t.id)
        for tid, n in trig_counts.items():
            if n > 1:
                line = next(t.line for t in inter.triggers if t.id == tid)
                self.diag.warn(
                    f"trigger id '{tid}' is used {n} times (OpenDS tolerates this)",
                    self.files["interaction"],
                    line,
                    "trigger",
                    once_key=f"dup-trigger:{tid}",
                )
        for t in inter.triggers:
            for a in t.activities:
                if a.ref and not a.actions:
                    self._need(a.ref in activities, "interaction", a.line, "activity", "activity ref", a.ref)
                elif not a.actions and not a.ref:
                    self.diag.warn("empty activity", self.files["interaction"], a.line, "activity")
            for c in t.condition.items:
                if isinstance(c, CollideWith):
                    self._need(
                        c.model_id in self.models,
                        "interaction",
                        t.line,
                        "condition",
                        "collideWith model",
                        c.model_id,
                        soft="the trigger never fires",
                    )
        for action in inter.all_actions():
            self._check_action(action)

    def _check_action(self, action) -> None:  # type: ignore[no-untyped-def]
        f = self.files["interaction"]
        spec = action_spec(action.name)
        if spec is None:
            self.diag.warn(
                f"unknown action '{action.name}' is skipped, as in OpenDS",
                f,
                action.line,
                "action",
                once_key=f"unknown-action:{action.name}",
            )
            return
        from .bind import ReadCtx

        ctx = ReadCtx(f, self.diag)
        values = {}
        for p in action.params:
            ps = spec.by_name.get(p.name)
            if ps is None:
                self.diag.warn(
                    f"action '{action.name}' has no parameter '{p.name}'; ignored",
                    f,
                    p.line,
                    "parameter",
                    once_key=f"param:{action.name}:{p.name}",
                )
                continue
            if p.value.strip():
                values[p.name] = parse_scalar(ps.codec, p.value, _LineEl(p.line), ctx, f"parameter '{p.name}' of {action.name}")
            else:
                values[p.name] = ""
        for ps in spec.params:
            if ps.required and not values.get(ps.name):
                raise TaskError(f"action '{action.name}' needs parameter '{ps.name}'", file=f, line=action.line, element="action")
        self._check_action_refs(action, values)

    def _check_action_refs(self, action, values: dict) -> None:  # type: ignore[no-untyped-def,type-arg]
        refs = {
            "manipulateObject": [("id", self.models, "scene model")],
            "manipulatePicture": [("id", self.pictures, "picture")],
            "playSound": [("soundID", self.sounds, "sound")],
            "pauseSound": [("soundID", self.sounds, "sound")],
            "stopSound": [("soundID", self.sounds, "sound")],
            "resetCar": [("resetPointID", self.reset_points | self.car_resets, "reset point")],
            "moveTraffic": [("trafficObjectID", self.traffic, "traffic object")],
            "requestGreenTrafficLight": [("trafficLightID", self.lights, "traffic light")],
            "setupLaneChangeReactionTimer": [
                ("startLane", self.lanes, "lane"),
                ("targetLane", self.lanes, "lane"),
                ("failSound", self.sounds, "sound"),
                ("successSound", self.sounds, "sound"),
            ],
            "setupBrakeReactionTimer": [("failSound", self.sounds, "sound"), ("successSound", self.sounds, "sound")],
        }.get(action.name, [])
        for pname, pool, what in refs:
            value = values.get(pname)
            if value:
                line = next((p.line for p in action.params if p.name == pname), action.line)
                self._need(
                    str(value) in pool,
                    "interaction",
                    line,
                    "parameter",
                    f"{action.name} {pname} ({what})",
                    str(value),
                    soft="the action does nothing",
                )

    # ------------------------------------------------------------------ task.xml
    def _check_task(self, task: TaskSpec, sc: Scenario) -> None:
        bars = self._unique("task", "distanceBar", ((b.id, b.line) for b in task.distance_bars))
        tvpt = task.three_vehicle_platoon
        if tvpt is not None:
            for band in (tvpt.leading_car, tvpt.follower_car):
                self._need(band.id in self.traffic, "task", tvpt.line, "threeVehiclePlatoon", "platoon car", band.id)
            ind = tvpt.distance_indicator
            if ind is not None:
                for bar in (ind.longitudinal_bar_id, ind.lateral_bar_id):
                    if bar:
                        self._need(bar in bars, "task", tvpt.line, "distanceIndicator", "distance bar", bar)
        st = task.steering_task
        if st is not None:
            for obj in (st.target_object, st.steering_object):
                if obj is not None:
                    self._need(obj.id in self.models, "task", st.line, "steeringTask", "ConTRe object", obj.id)
            if st.traffic_light_object_id:
                self._need(
                    st.traffic_light_object_id in self.models,
                    "task",
                    st.line,
                    "trafficLightObject",
                    "ConTRe light",
                    st.traffic_light_object_id,
                )
            for ref in (st.start_point_ref, st.end_point_ref):
                if ref:
                    self._need(ref in self.points, "task", st.line, "steeringTask", "ConTRe point", ref)


class _LineEl:
    """Stands in for an element where only the line is known (parameter values)."""

    def __init__(self, line: int) -> None:
        self.sourceline = line
        self.tag = "parameter"

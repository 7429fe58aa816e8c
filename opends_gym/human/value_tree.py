"""The settings-controller value tree: `/root/thisVehicle/...` paths read from a snapshot.

Why: OpenDS's settings-controller clients (the Java test client, lab dashboards) ask for
values by path (`assets/Interface/SettingsControllerAPI.xml`, OpenDS
`SettingsControllerServer`; docs/opends-compatibility.md#settings-controller) and get them back as an XML
tree. This is the subset our simulation can answer truthfully;
paths are matched by substring as OpenDS does, and the older `.../Properties/...` form
is accepted too.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

from lxml import etree

from .snapshot import VehicleSnapshot

V = "/root/thisVehicle"


def _b(v: bool) -> str:
    return "true" if v else "false"


VALUE_PATHS: dict[str, Callable[[VehicleSnapshot], str]] = {
    f"{V}/interior/cockpit/pedals/gasPedal/pressedState": lambda s: f"{s.accelerator:.4f}",
    f"{V}/interior/cockpit/pedals/brakePedal/pressedState": lambda s: f"{s.brake:.4f}",
    f"{V}/interior/cockpit/pedals/clutch/pressedState": lambda s: f"{s.clutch:.4f}",
    f"{V}/interior/cockpit/handBrake/engaged": lambda s: _b(s.hand_brake),
    f"{V}/interior/cockpit/steeringWheel/steerAngle": lambda s: f"{-s.steering * s.max_steering_deg:.3f}",
    f"{V}/interior/cockpit/autoPilot/state": lambda s: _b(s.autopilot),
    f"{V}/interior/cockpit/cruiseControl/state": lambda s: _b(s.cruise_active),
    f"{V}/interior/cockpit/dashboard/speedLimit": lambda s: f"{s.speed_limit_kmh:.1f}",
    f"{V}/exterior/lights/turnSignalState": lambda s: s.turn_signal,
    f"{V}/exterior/gearUnit/currentGear": lambda s: str(s.gear),
    f"{V}/exterior/gearUnit/currentTransmission": lambda s: "automatic" if s.automatic else "manual",
    f"{V}/exterior/engineCompartment/engine/running": lambda s: "1" if s.engine_on else "0",
    f"{V}/exterior/engineCompartment/engine/actualRpm": lambda s: str(int(s.rpm)),
    f"{V}/exterior/fueling/fuelType/currentConsumption": lambda s: f"{s.l_per_100km:.3f}",
    f"{V}/exterior/fueling/fuelType/averageConsumption": lambda s: (
        f"{(100000.0 * s.fuel_used_l / s.odometer_m) if s.odometer_m > 0 else 0.0:.3f}"
    ),
    f"{V}/exterior/fueling/fuelType/tank/maxAmount": lambda s: f"{s.fuel_used_l + s.fuel_left_l:.3f}",
    f"{V}/exterior/fueling/fuelType/tank/actualAmount": lambda s: f"{s.fuel_left_l:.3f}",
    f"{V}/physicalAttributes/length": lambda s: f"{s.length_m:.3f}",
    f"{V}/physicalAttributes/width": lambda s: f"{s.width_m:.3f}",
    f"{V}/physicalAttributes/height": lambda s: f"{s.height_m:.3f}",
    f"{V}/physicalAttributes/weight": lambda s: f"{s.mass_kg:.1f}",
    f"{V}/physicalAttributes/orientation": lambda s: f"{s.heading_deg:.3f}",
    f"{V}/physicalAttributes/speed": lambda s: f"{s.speed_kmh:.3f}",
    f"{V}/physicalAttributes/mileage": lambda s: f"{s.odometer_m / 1000.0:.4f}",
    f"{V}/physicalAttributes/accelerationLongitudinal": lambda s: f"{s.accel_long_mps2:.4f}",
    f"{V}/physicalAttributes/accelerationLateral": lambda s: f"{s.accel_lat_mps2:.4f}",
    f"{V}/physicalAttributes/yawRate": lambda s: f"{-s.yaw_rate_rps * 57.29577951308232:.4f}",
    f"{V}/simulationAttributes/modelX": lambda s: f"{s.x_m:.4f}",
    f"{V}/simulationAttributes/modelY": lambda s: f"{s.y_m:.4f}",
    f"{V}/simulationAttributes/modelZ": lambda s: f"{s.z_m:.4f}",
    f"{V}/simulationAttributes/simulationTime": lambda s: f"{s.t_s:.4f}",
    f"{V}/simulationAttributes/paused": lambda s: _b(s.paused),
    f"{V}/roadAttributes/position/laneID": lambda s: s.lane_id or "",
    f"{V}/roadAttributes/regulations/currentSpeedLimit": lambda s: f"{s.speed_limit_kmh:.1f}",
    f"{V}/roadAttributes/traffic/numObjs": lambda s: str(len(s.traffic)),
    f"{V}/roadAttributes/traffic/objName": lambda s: ",".join(t[0] for t in s.traffic),
    f"{V}/roadAttributes/traffic/objX": lambda s: ",".join(f"{t[1]:.3f}" for t in s.traffic),
    f"{V}/roadAttributes/traffic/objY": lambda s: ",".join(f"{t[2]:.3f}" for t in s.traffic),
    f"{V}/roadAttributes/traffic/objVel": lambda s: ",".join(f"{t[3]:.3f}" for t in s.traffic),
}


def normalise_request(path: str) -> str:
    """OpenDS 4.x clients say `.../physicalAttributes/Properties/speed`; the tree has no `Properties`."""
    return path.strip().replace("/Properties/", "/").replace("/Properties", "")


def matching_paths(request: str) -> list[str]:
    """Paths containing the request (OpenDS subscribes by substring); an empty request matches none."""
    r = normalise_request(request)
    if not r:
        return []
    return [p for p in VALUE_PATHS if r in p]


def build_tree(paths: Iterable[str], snapshot: VehicleSnapshot | None, names_only: bool = False) -> etree._Element:
    """`<root><thisVehicle>...` holding the given paths (values unless `names_only`)."""
    root = etree.Element("root")
    for path in sorted(paths):
        node = root
        for part in path.split("/")[2:]:
            child = node.find(part)
            node = child if child is not None else etree.SubElement(node, part)
        if not names_only and snapshot is not None:
            try:
                node.text = VALUE_PATHS[path](snapshot)
            except Exception:  # a value that cannot be computed is sent empty
                node.text = ""
    return root


def schema_tree() -> etree._Element:
    return build_tree(VALUE_PATHS, None, names_only=True)

"""Test doubles for human-mode tests: a scripted CAN gateway server and task geometry."""

from __future__ import annotations

import math
import re
import socket
import threading
import time
from dataclasses import dataclass
from typing import Any

from opends_gym.task import load_task
from opends_gym.task.conditions import CollideWith

FEEDBACK = re.compile(r"\$SimCarState#([^#]*)#([^#]*)#([^#]*)#([^%]*)%")


@dataclass(frozen=True)
class Trial:
    z_m: float  # the trigger box: the sign appears when the car passes it (driving towards -Z)
    kind: str  # brake | lane
    target_x_m: float = 0.0


def reaction_test_plan(task_name: str = "ReactionTest") -> tuple[list[Trial], float]:
    """The ReactionTest trials (trigger z, kind, target lane centre x) and the centre lane's x."""
    task = load_task(task_name)
    lanes = {lane.id: 0.5 * (lane.x_min_m + lane.x_max_m) for lane in task.scenario.road.lanes}
    z_of: dict[str, float] = {}
    for m in task.scene.models:
        if m.id and m.translation_m is not None:
            z_of[m.id] = m.translation_m[2]
    trials: list[Trial] = []
    for trig in task.interaction.triggers:
        models = [c.model_id for c in trig.condition.items if isinstance(c, CollideWith)]
        if not models or models[0] not in z_of:
            continue
        for act in (a for activity in task.interaction.resolved_activities(trig) for a in activity.actions):
            params = {p.name: p.value for p in act.params}
            if act.name == "setupBrakeReactionTimer":
                trials.append(Trial(z_of[models[0]], "brake"))
            elif act.name == "setupLaneChangeReactionTimer":
                trials.append(Trial(z_of[models[0]], "lane", lanes[params["targetLane"]]))
    return sorted(trials, key=lambda t: -t.z_m), lanes["2"]


class ScriptedGateway:
    """Plays OpenDS's CAN gateway: a TCP server the simulator connects to.

    `controller(feedback) -> str | None` maps the simulator's `$SimCarState` feedback
    (speed km/h, heading deg, x, z) to a message to send back.
    """

    def __init__(self, controller: Any = None) -> None:
        self.server = socket.create_server(("127.0.0.1", 0))
        self.server.settimeout(0.2)
        self.port = self.server.getsockname()[1]
        self.controller = controller
        self.feedback: list[tuple[float, float, float, float]] = []
        self.received = b""
        self.connections = 0
        self.replies = 0  # messages the controller sent back
        self.answered = 0  # feedback messages received when the controller last answered
        self.conn: socket.socket | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                conn, _ = self.server.accept()
            except (TimeoutError, OSError):
                continue
            self.connections += 1
            self.conn = conn
            conn.settimeout(0.05)
            buf = ""
            try:
                while not self._stop.is_set():
                    try:
                        data = conn.recv(65536)
                    except TimeoutError:
                        continue
                    if not data:
                        break
                    self.received += data
                    buf += data.decode("utf-8", "replace")
                    last = None
                    for m in FEEDBACK.finditer(buf):
                        last = tuple(float(g) for g in m.groups())
                        self.feedback.append(last)  # type: ignore[arg-type]
                    buf = buf[buf.rfind("%") + 1 :] if "%" in buf else buf
                    if last is not None and self.controller is not None:
                        reply = self.controller(last)
                        if reply:
                            conn.sendall(reply.encode())
                            self.replies += 1
                        self.answered = len(self.feedback)
            except OSError:
                pass
            finally:
                conn.close()
                self.conn = None

    def send(self, data: bytes) -> None:
        for _ in range(200):
            if self.conn is not None:
                self.conn.sendall(data)
                return
            threading.Event().wait(0.01)
        raise AssertionError("the simulator never connected")

    def wait_received(self, suffix: bytes, timeout_s: float = 5.0) -> bool:
        """Wait until what the simulator sent ends with `suffix` (its reader thread may lag)."""
        end = time.monotonic() + timeout_s
        while not self.received.endswith(suffix) and time.monotonic() < end:
            time.sleep(0.01)
        return self.received.endswith(suffix)

    def drop(self) -> None:
        """Cut the current connection abruptly."""
        if self.conn is not None:
            self.conn.shutdown(socket.SHUT_RDWR)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)
        self.server.close()


class Lockstep:
    """Holds a `--fast` session at each feedback its CAN gateway source sends until the scripted
    gateway has answered it and the source has parsed the answer, so the closed loop runs on
    simulation time: the answer drives the next physics step however long the gateway's thread
    waited for a core (free running, a loaded host let the car run a second or two ahead of
    its driver and miss the lane change). `stalls` counts answers that never came (the session
    reports a failing feedback as a warning only)."""

    def __init__(self, source: Any, gateway: ScriptedGateway, timeout_s: float = 30.0) -> None:
        self.source, self.gateway, self.timeout_s = source, gateway, timeout_s
        self.sent = 0
        self.stalls = 0
        self._send = source.feedback
        source.feedback = self.feedback  # (the session calls the instance's feedback after each step)

    def feedback(self, snapshot: Any) -> bool:
        if not self._send(snapshot):
            return False
        self.sent += 1
        gw, src = self.gateway, self.source
        end = time.monotonic() + self.timeout_s
        while gw.answered < self.sent and time.monotonic() < end:
            time.sleep(0.0002)  # (a round trip on the loopback takes well under a millisecond)
        replies = gw.replies
        while src.messages_received < replies and time.monotonic() < end:
            time.sleep(0.0002)
        if src.messages_received < replies or gw.answered < self.sent:
            self.stalls += 1
        return True


class ReactionTestDriver:
    """A gateway-side driver for ReactionTest: keeps ~55 km/h, brakes or changes lane per trial."""

    def __init__(self) -> None:
        self.trials, self.centre_x = reaction_test_plan()

    def __call__(self, fb: tuple[float, float, float, float]) -> str:
        speed, heading, x, z = fb
        active = [t for t in self.trials if t.z_m > z > t.z_m - (45.0 if t.kind == "brake" else 117.0)]
        trial = active[-1] if active else None
        target_x = trial.target_x_m if trial is not None and trial.kind == "lane" else self.centre_x
        accel, brake = (0.17 if speed < 55.0 else 0.0), 0.0
        if trial is not None and trial.kind == "brake":
            accel, brake = 0.0, (0.6 if speed > 33.0 else 0.0)
        yaw = -math.radians(heading if heading <= 180.0 else heading - 360.0)
        yaw_des = max(-0.12, min(0.12, -0.08 * (target_x - x)))
        steer = max(-0.3, min(0.3, 3.0 * (yaw_des - yaw)))
        deg = -steer * 270.0
        return (
            f'<message><action name="steering">{deg:.3f}</action>'
            f'<action name="acceleration">{accel:.3f}</action><action name="brake">{brake:.3f}</action></message>'
        )


EXTRA_TRIGGERS = """
            <trigger id="ReportKeyTrigger" priority="1">
                  <activities>
                        <activity id="ReportKeyActivity">
                              <action delay="0" id="sendMessage" repeat="0">
                                    <parameter name="text" value="reaction reported"/>
                                    <parameter name="duration" value="2"/>
                              </action>
                        </activity>
                  </activities>
                  <condition>pressKey:KEY_G</condition>
            </trigger>
            <trigger id="WheelButtonTrigger" priority="1">
                  <activities>
                        <activity id="WheelButtonActivity">
                              <action delay="0" id="reportText" repeat="0">
                                    <parameter name="text" value="button pressed"/>
                              </action>
                        </activity>
                  </activities>
                  <condition>pressButton:3</condition>
            </trigger>
            <trigger id="RemoteHonkTrigger" priority="1">
                  <activities>
                        <activity id="RemoteHonkActivity">
                              <action delay="0" id="sendMessage" repeat="0">
                                    <parameter name="text" value="remote honk"/>
                                    <parameter name="duration" value="2"/>
                              </action>
                        </activity>
                  </activities>
                  <condition>remote:honk</condition>
            </trigger>
            <trigger id="KeyTimerTrigger" priority="1">
                  <activities>
                        <activity id="KeyTimerActivity">
                              <action delay="0" id="startReactionMeasurement" repeat="0"/>
                              <action delay="0" id="setupKeyReactionTimer" repeat="0">
                                    <parameter name="timerID" value="keyTimer"/>
                                    <parameter name="reactionGroup" value="WheelButton"/>
                                    <parameter name="correctReaction" value="JOY_3"/>
                                    <parameter name="failureReaction" value="KEY_F"/>
                              </action>
                        </activity>
                  </activities>
                  <condition>pressKey:KEY_L</condition>
            </trigger>
      </triggers>"""


def reaction_test_with_extra_triggers(task_copy: Any) -> Any:
    """The corpus ReactionTest plus pressKey:KEY_G, pressButton:3, remote:honk and a key reaction
    timer armed by pressKey:KEY_L that button 3 of the wheel answers (JOY_3)."""
    return task_copy("opends-cts/ReactionTest", "interaction.xml", "      </triggers>", EXTRA_TRIGGERS)


def _point(pid: str, x: float, z: float) -> str:
    entries = "".join(f"<entry>{v}</entry>" for v in (x, 0.0, z))
    return f'<point id="{pid}"><translation><vector jtype="java_lang_Float" size="3">{entries}</vector></translation></point>'


IDEAL_TRACK = (
    '<driver>\n<idealTracks><idealTrack id="centreLine" roadWidth="15">'
    + "".join(_point(f"ip{i}", 1.0, 24500.0 - 40.0 * i) for i in range(12))
    + "</idealTrack></idealTracks>"
)


def reaction_test_with_ideal_track(task_copy: Any) -> Any:
    """The corpus ReactionTest with an ideal track along the road at x = 1 m."""
    return task_copy("opends-cts/ReactionTest", "scenario.xml", "<driver>", IDEAL_TRACK)


def wait_for(cond, timeout_s: float = 5.0) -> None:  # type: ignore[no-untyped-def]
    """Poll `cond` every 10 ms until it holds; AssertionError after `timeout_s`."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if cond():
            return
        time.sleep(0.01)
    raise AssertionError("timed out")

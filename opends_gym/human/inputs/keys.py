"""OpenDS function ids, their default keys, and pygame key codes as jME key names.

Why: OpenDS's settings.xml and interaction.xml name keys the jMonkeyEngine way
(`KEY_RETURN`, `KEY_PGUP`, `SPACE`); the window reports pygame key codes. This module is
the one dictionary between the two, plus OpenDS's default key table
(`eu.opends.input.KeyMapping`), so a participant's muscle memory from OpenDS carries over.
"""

from __future__ import annotations

from ...task.conditions import canonical_key

# OpenDS function id -> default keys (jME names; BUTTON_n are joystick buttons).
DEFAULT_KEYS: dict[str, tuple[str, ...]] = {
    "toggle_keymapping": ("KEY_F1",),
    "shutdown": ("KEY_ESCAPE",),
    "toggle_cam": ("KEY_V",),
    "toggle_messagebox": ("KEY_M",),
    "accelerate": ("KEY_UP",),
    "accelerate_back": ("KEY_DOWN",),
    "steer_left": ("KEY_LEFT",),
    "steer_right": ("KEY_RIGHT",),
    "brake": ("KEY_SPACE",),
    "toggle_engine": ("KEY_E",),
    "toggle_pause": ("KEY_P",),
    "start_pause": ("KEY_O",),
    "stop_pause": ("KEY_I",),
    "toggle_trafficlightmode": ("KEY_A",),
    "toggle_record_data": ("KEY_S",),
    "toggle_topview": ("KEY_U",),
    "toggle_backmirror": ("KEY_BACK",),
    "shift_up": ("KEY_PGUP",),
    "shift_down": ("KEY_PGDN",),
    "toggle_automatic": ("KEY_END",),
    "horn": ("KEY_H",),
    "toggle_min_speed": ("KEY_D",),
    "cruise_control": ("KEY_X",),
    "reset_car": ("KEY_R",),
    **{f"reset_car_pos{i}": (f"KEY_{i % 10}",) for i in range(1, 11)},
    "reset_fuel_consumption": ("KEY_T",),
    "toggle_stats": ("KEY_F4",),
    "toggle_cinematics": ("KEY_RETURN",),
    "toggle_headlight": ("KEY_L",),
    "report_landmark": ("KEY_SPACE",),
    "close_instruction_screen": ("KEY_F5",),
    "report_reaction": ("KEY_G", "BUTTON_8"),
    "toggle_handbrake": (),  # OpenDS binds KEY_H, which the horn already uses; assign it in settings.xml
    "turn_left": ("KEY_J",),
    "turn_right": ("KEY_K",),
    "hazard_lights": ("KEY_F",),
    "cc_inc5": (),  # OpenDS: KEY_9 / KEY_8, taken by reset_car_pos9/8 unless reassigned
    "cc_dec5": (),
    "snow_inc5": ("KEY_F12",),
    "snow_dec5": ("KEY_F11",),
    "rain_inc5": ("KEY_F10",),
    "rain_dec5": ("KEY_F9",),
    "fog_inc5": ("KEY_F8",),
    "fog_dec5": ("KEY_F7",),
    "gear1": ("BUTTON_8",),
    "gear2": ("BUTTON_9",),
    "gear3": ("BUTTON_10",),
    "gear4": ("BUTTON_11",),
    "gear5": ("BUTTON_12",),
    "gear6": ("BUTTON_13",),
    "gearR": ("BUTTON_14",),
}

# Functions handled by the runner (display, session) rather than the car.
RUNNER_FUNCTIONS = frozenset(
    {
        "toggle_keymapping",
        "shutdown",
        "toggle_cam",
        "toggle_messagebox",
        "toggle_pause",
        "start_pause",
        "stop_pause",
        "toggle_record_data",
        "toggle_topview",
        "toggle_backmirror",
        "toggle_stats",
        "toggle_cinematics",
        "close_instruction_screen",
        "reset_fuel_consumption",
        "toggle_trafficlightmode",
        "toggle_headlight",
        "report_landmark",
        "snow_inc5",
        "snow_dec5",
        "rain_inc5",
        "rain_dec5",
        "fog_inc5",
        "fog_dec5",
    }
)


def normalise_binding(key: str) -> str:
    """A settings.xml key name in canonical form: `SPACE` -> `KEY_SPACE`, `button_3` -> `BUTTON_3`."""
    return canonical_key(key)


def key_table(assignments: object = (), defaults: dict[str, tuple[str, ...]] | None = None) -> dict[str, tuple[str, ...]]:
    """Function -> keys: the defaults with settings.xml `keyAssignment`s replacing them.

    As in OpenDS, a function named in settings.xml loses its default keys; several
    assignments of one function accumulate. Unknown function ids are kept (pressKey
    triggers do not need them, but a custom build might).
    """
    table = dict(DEFAULT_KEYS if defaults is None else defaults)
    replaced: set[str] = set()
    for a in assignments or ():  # type: ignore[attr-defined]
        func = str(getattr(a, "function", "")).strip()
        key = str(getattr(a, "key", "")).strip()
        if not func or not key:
            continue
        if func not in replaced:
            table[func] = ()
            replaced.add(func)
        table[func] = table[func] + (normalise_binding(key),)
    return table


def invert_table(table: dict[str, tuple[str, ...]]) -> dict[str, tuple[str, ...]]:
    """Key -> functions it triggers (one key may serve several, e.g. SPACE brakes and reports)."""
    out: dict[str, tuple[str, ...]] = {}
    for func, keys in table.items():
        for k in keys:
            out[k] = out.get(k, ()) + (func,)
    return out


def _pygame_names() -> dict[int, str]:
    import pygame

    names: dict[int, str] = {}
    for c in "abcdefghijklmnopqrstuvwxyz":
        names[getattr(pygame, f"K_{c}")] = f"KEY_{c.upper()}"
    for d in range(10):
        names[getattr(pygame, f"K_{d}")] = f"KEY_{d}"
        names[getattr(pygame, f"K_KP{d}")] = f"KEY_NUMPAD{d}"
    for n in range(1, 16):
        names[getattr(pygame, f"K_F{n}")] = f"KEY_F{n}"
    simple = {
        "K_RETURN": "KEY_RETURN",
        "K_SPACE": "KEY_SPACE",
        "K_UP": "KEY_UP",
        "K_DOWN": "KEY_DOWN",
        "K_LEFT": "KEY_LEFT",
        "K_RIGHT": "KEY_RIGHT",
        "K_PAGEUP": "KEY_PGUP",
        "K_PAGEDOWN": "KEY_PGDN",
        "K_HOME": "KEY_HOME",
        "K_END": "KEY_END",
        "K_INSERT": "KEY_INSERT",
        "K_DELETE": "KEY_DELETE",
        "K_BACKSPACE": "KEY_BACK",
        "K_ESCAPE": "KEY_ESCAPE",
        "K_TAB": "KEY_TAB",
        "K_LSHIFT": "KEY_LSHIFT",
        "K_RSHIFT": "KEY_RSHIFT",
        "K_LCTRL": "KEY_LCONTROL",
        "K_RCTRL": "KEY_RCONTROL",
        "K_LALT": "KEY_LMENU",
        "K_RALT": "KEY_RMENU",
        "K_CAPSLOCK": "KEY_CAPITAL",
        "K_PAUSE": "KEY_PAUSE",
        "K_MINUS": "KEY_MINUS",
        "K_EQUALS": "KEY_EQUALS",
        "K_COMMA": "KEY_COMMA",
        "K_PERIOD": "KEY_PERIOD",
        "K_SLASH": "KEY_SLASH",
        "K_BACKSLASH": "KEY_BACKSLASH",
        "K_SEMICOLON": "KEY_SEMICOLON",
        "K_QUOTE": "KEY_APOSTROPHE",
        "K_BACKQUOTE": "KEY_GRAVE",
        "K_LEFTBRACKET": "KEY_LBRACKET",
        "K_RIGHTBRACKET": "KEY_RBRACKET",
        "K_KP_ENTER": "KEY_NUMPADENTER",
        "K_KP_PLUS": "KEY_ADD",
        "K_KP_MINUS": "KEY_SUBTRACT",
        "K_KP_MULTIPLY": "KEY_MULTIPLY",
        "K_KP_DIVIDE": "KEY_DIVIDE",
        "K_KP_PERIOD": "KEY_DECIMAL",
    }
    for attr, jme in simple.items():
        code = getattr(pygame, attr, None)
        if code is not None:
            names[code] = jme
    return names


_PYGAME: dict[int, str] | None = None


def jme_key_name(pygame_key: int) -> str | None:
    """The jME name of a pygame key code (`pygame.K_PAGEUP` -> `KEY_PGUP`), None if unmapped."""
    global _PYGAME
    if _PYGAME is None:
        _PYGAME = _pygame_names()
    return _PYGAME.get(pygame_key)

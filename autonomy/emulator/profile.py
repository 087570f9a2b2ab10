"""Robot profiles: one robot's emulator settings (the fields of :class:`RobotParams`) in a YAML file.

``autonomy calibrate`` writes one from a robot's own runs; wherever an emulator is made it can
take one (``emu://?profile=robot-3.yaml``, ``autonomy run --profile``, ``autonomy emulator
--profile``, an exercise's ``robot:``). A field the file leaves out keeps its default::

    name: robot-3
    speed_setting_v: [10.12, 19.87, 29.71, 39.4]
    acceleration_mm_s2: 1380
    turn_rate_deg_s: 84.2
    command_delay_s: 0.04

Every problem is said at its place, ``FILE:LINE:COL: PATH: message``, as a world file's are.
"""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path
from typing import Any

from autonomy.emulator.robot import RobotParams
from autonomy.emulator.world import WorldInvalid
from autonomy.source import Located, Problem, Reader, UnreadableFile, parse, read_text, shown, suggest

#: Each field a profile may set: the lowest and highest value it takes, and whether it is a whole number.
RANGES: dict[str, tuple[float, float, bool]] = {
    "wheel_diameter_mm": (10.0, 500.0, False),
    "speed_setting_v": (0.1, 99.0, False),  # each of the four
    "acceleration_mm_s2": (10.0, 50_000.0, False),
    "turn_rate_deg_s": (1.0, 3600.0, False),
    "command_delay_s": (0.0, 0.3, False),  # a move's blocked check gives a robot 0.5 s to start
    "body_radius_mm": (10.0, 500.0, False),
    "servo_speed_deg_s": (1.0, 10_000.0, False),
    "sensor_max_mm": (1, 255, True),
    "sensor_cone_deg": (0.0, 180.0, False),
    "sensor_noise_mm": (0.0, 100.0, False),
    "sensor_scale": (0.5, 2.0, False),
    "sensor_offset_mm": (-100.0, 100.0, False),
    "battery_start": (0.0, 255.0, False),
    "battery_idle_drain_per_s": (0.0, 10.0, False),
    "battery_motion_drain_per_s": (0.0, 10.0, False),
    "battery_unhealthy_below": (0.0, 255.0, False),
    "battery_cutoff_below": (0.0, 255.0, False),
    "collision_hold_s": (0.0, 10.0, False),
    "impact_tilt_deg_per_mm_s": (0.0, 1.0, False),
    "tilt_time_constant_s": (0.001, 10.0, False),
    "step_s": (0.001, 0.05, False),
}
#: The keys a profile may hold besides the settings: what it is called and a line about it.
ABOUT_KEYS = ("name", "description")
#: What ``GF`` answers: three printable characters (PROTOCOL.md).
FIRMWARE = re.compile(r"[!-~]{3}")


class ProfileInvalid(WorldInvalid):
    """A robot profile with problems (said as a world file's are); :attr:`problems` lists every one."""


@dataclasses.dataclass(frozen=True)
class Profile:
    """A robot's settings, and what the file called it."""

    name: str
    params: RobotParams
    description: str = ""


def _keys() -> tuple[str, ...]:
    return (*ABOUT_KEYS, *RANGES, "firmware_version")


class _Reader(Reader):
    def profile(self, root: Located, default_name: str) -> Profile | None:
        if not isinstance(root.value, dict):
            self.problem(root, "", "expected a mapping of the robot's settings, e.g. turn_rate_deg_s: 88.5")
            return None
        allowed = _keys()
        values: dict[str, Any] = {}
        for key, located in root.value.items():
            if key not in allowed:
                hint = suggest(key, list(allowed)) or " (a profile sets the fields of RobotParams: docs/robots.md)"
                self.problem(root.keys[key], key, f"unknown key '{key}'{hint}")
                continue
            if key in ABOUT_KEYS:
                values[key] = self.text(located, key)
            elif key == "firmware_version":
                if isinstance(located.value, str) and FIRMWARE.fullmatch(located.value):
                    values[key] = located.value
                else:
                    self.problem(located, key, f"expected three printable characters, got {located.plain!r}")
            elif key == "speed_setting_v":
                values[key] = self._speeds(located)
            else:
                low, high, whole = RANGES[key]
                values[key] = self.number(located, key, low, high, whole)
        if self.problems:
            return None
        params = RobotParams(**{k: v for k, v in values.items() if k in RANGES})
        if "firmware_version" in values:
            params = dataclasses.replace(params, firmware_version=values["firmware_version"])
        if params.battery_cutoff_below > params.battery_unhealthy_below:
            self.problem(
                root.value.get("battery_cutoff_below", root),
                "battery_cutoff_below",
                f"must not be above battery_unhealthy_below ({shown(params.battery_unhealthy_below)}): a robot "
                "that refuses to move is also unhealthy",
            )
            return None
        return Profile(values.get("name") or default_name, params, values.get("description") or "")

    def _speeds(self, located: Located) -> tuple[float, float, float, float] | None:
        if not (isinstance(located.value, list) and len(located.value) == 4):
            self.problem(
                located, "speed_setting_v", f"expected the four speeds' [V1, V2, V3, V4], got {located.plain!r}"
            )
            return None
        low, high, _ = RANGES["speed_setting_v"]
        speeds = [self.number(item, f"speed_setting_v[{i}]", low, high) for i, item in enumerate(located.value)]
        if any(speed is None for speed in speeds):
            return None
        return (speeds[0], speeds[1], speeds[2], speeds[3])


def parse_profile_text(text: str, label: str = "<profile>", default_name: str = "robot") -> Profile:
    """Reads a profile's text.

    Raises:
        ProfileInvalid: with every problem, each at its place.
    """
    located, errors = parse(text)
    if located is None or errors:
        raise ProfileInvalid([Problem(label, e.line, e.column, "", e.message) for e in errors])
    reader = _Reader(label)
    profile = reader.profile(located, default_name)
    if reader.problems or profile is None:
        raise ProfileInvalid(reader.problems or [Problem(label, 1, 1, "", "not a robot profile")])
    return profile


def load_profile(path: str | Path) -> Profile:
    """Reads the profile file at ``path``.

    Raises:
        ProfileInvalid: the file cannot be read, or has problems (each at its place).
    """
    try:
        text = read_text(path)
    except UnreadableFile as err:
        raise ProfileInvalid(
            [Problem(str(path), err.line, err.column, "", f"cannot read the robot profile: {err.reason}")]
        ) from None
    return parse_profile_text(text, str(path), Path(path).stem)


def profile_text(params: RobotParams, name: str, notes: dict[str, str] | None = None) -> str:
    """A profile file's text for ``params``: the settings that differ from the defaults, each with its note.

    Args:
        params: The settings.
        name: What the profile calls the robot.
        notes: A comment for a setting, by field (how well it was fitted, or why it was left).
    """
    notes = notes or {}
    defaults = RobotParams()
    lines = [f"name: {name}"]
    for f in dataclasses.fields(RobotParams):
        if f.name not in RANGES and f.name != "firmware_version":
            continue
        value, default = getattr(params, f.name), getattr(defaults, f.name)
        if value == default and f.name not in notes:
            continue
        if isinstance(value, tuple):
            shown_value = "[" + ", ".join(_number(v) for v in value) + "]"
        elif isinstance(value, str):
            shown_value = value
        else:
            shown_value = _number(value)
        note = f"  # {notes[f.name]}" if f.name in notes else ""
        lines.append(f"{f.name}: {shown_value}{note}")
    return "\n".join(lines) + "\n"


def _number(value: float) -> str:
    """A setting as the file holds it: four significant decimals are far finer than any fit."""
    if isinstance(value, int):
        return str(value)
    return f"{value:.6g}"

"""An emulator of the robot: world, physics, firmware, wire faults, and ways to reach it.

Reach it in-process with the ``emu://`` URL, over TCP with ``socket://`` (see
:mod:`autonomy.emulator.servers`), or through a pseudo-terminal.
"""

from autonomy.emulator.core import OPTIONS, Emulator, Exchange, emulator_from_options
from autonomy.emulator.faults import FaultSpec, FaultSpecError
from autonomy.emulator.profile import Profile, ProfileInvalid, load_profile, parse_profile_text, profile_text
from autonomy.emulator.robot import Robot, RobotParams
from autonomy.emulator.world import (
    Box,
    Circle,
    Jitter,
    Pose,
    World,
    WorldError,
    WorldInvalid,
    Zone,
    load_world,
    parse_world_text,
    world_from_dict,
)

__all__ = [
    "OPTIONS",
    "Box",
    "Circle",
    "Emulator",
    "Exchange",
    "FaultSpec",
    "FaultSpecError",
    "Jitter",
    "Pose",
    "Profile",
    "ProfileInvalid",
    "Robot",
    "RobotParams",
    "World",
    "WorldError",
    "WorldInvalid",
    "Zone",
    "emulator_from_options",
    "load_profile",
    "load_world",
    "parse_profile_text",
    "parse_world_text",
    "profile_text",
    "world_from_dict",
]

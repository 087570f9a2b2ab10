"""Fitting the emulator's settings to a robot's own runs, by least squares (``scipy.optimize.least_squares``).

The model is the emulator's own motion, worked out in closed form so that it is smooth in its
settings: a motion command acts ``command_delay_s`` after it was sent; the wheels speed up and
slow down at ``acceleration_mm_s2`` towards the speed of the setting (a move) or to a standstill
(a stop, and a turn, which also stops the wheels at once); a turn turns in place at
``turn_rate_deg_s`` until its angle is done. The fit finds the settings for which that model
says, at each sample's time, the odometer and the heading the robot reported. The emulator
drives each of its steps at the speed it reaches at the step's end, so that a change of speed
runs half a step ahead of the same change made smoothly: the model has moves and stops act that
much earlier (``speed_lead_s``, half the emulator's step), so that the delay it finds is the one
that, given to the emulator, starts its wheels when the robot's started.

Each recording is cut into pieces where the robot stood still (at least ``REST_S``) before it was
told to move or turn: the model starts each piece from the odometer and heading reported there
(``LEAD_IN_S`` before the command, so that the command may act early within the piece), so
that a miss in one piece is not carried into the next. Each command may also have acted a little
late or early, by up to ``LATENESS_S``, beyond the common delay: a link and a robot's own control
loop act on a command a few milliseconds apart, each time a little differently. Those are fitted
too, each held to zero by a weight (``LATENESS_MM_PER_S``: 1 mm of miss is 5 ms of lateness), so
that the acceleration is read from the shape of each start and stop, not from when it began.

The front sensor is fitted on its own, by a straight line: its readings against the true
distance to the wall, which a probe knows (it started a measured distance from a wall and drove
straight at it). Its noise is what that line leaves, less the rounding of whole millimetres.

A setting the runs do not excite (a speed never driven at, a turn never made) is left where it
was and said so; so is one the runs hold too little of to pin down.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

from autonomy.calibration.recording import Recording, Sample, Sent
from autonomy.emulator.robot import RobotParams

#: The motion settings fitted, in the fit's own units (ground speeds in mm/s).
MOTION = (
    "speed_1_mm_s",
    "speed_2_mm_s",
    "speed_3_mm_s",
    "speed_4_mm_s",
    "acceleration_mm_s2",
    "turn_rate_deg_s",
    "command_delay_s",
)
#: The range a fit may search for each: far wider than any robot of this kind.
BOUNDS = {
    "speed_1_mm_s": (1.0, 2000.0),
    "speed_2_mm_s": (1.0, 2000.0),
    "speed_3_mm_s": (1.0, 2000.0),
    "speed_4_mm_s": (1.0, 2000.0),
    "acceleration_mm_s2": (50.0, 20_000.0),
    "turn_rate_deg_s": (5.0, 2000.0),
    "command_delay_s": (0.0, 0.3),  # as a profile takes it
}
#: How far each setting is moved to see whether the runs depend on it: a tenth (a delay: 20 ms).
PROBE_STEP = {"command_delay_s": 0.02}
PROBE_SHARE = 0.1
#: A setting whose probe step moves the prediction by less than this (mm and degrees, over all the
#: samples together) is not excited by the runs.
EXCITED_BELOW = 3.0
#: A fitted setting whose uncertainty is more than this share of its value is too loosely held (a delay: 20 ms).
LOOSE_SHARE = 0.05
LOOSE_DELAY_S = 0.02
#: The readings a sensor fit needs, and the span of distances they must cover, mm.
SENSOR_SAMPLES = 10
SENSOR_SPAN_MM = 50.0
#: Readings this close to the sensor's largest are left out of its fit (noise there is cut off).
SENSOR_EDGE_MM = 5.0
#: Most samples one fit takes (its time and memory grow with them and with the commands).
MAX_SAMPLES = 20_000
#: A stand-still this long before a move or turn starts a piece of a recording, seconds.
REST_S = 0.3
#: How late (or early) a command may act beyond the common delay, seconds.
LATENESS_S = 0.03
#: How long before its first command a piece starts (on a sample of the robot standing still), seconds:
#: more than the earliest that command may act (:data:`LATENESS_S` early), so that it acts within the piece.
LEAD_IN_S = 0.1
#: A command's lateness weighs in the fit as a miss of this many mm per second of it.
LATENESS_MM_PER_S = 200.0
#: The variance of rounding to whole millimetres, mm²: a reading and the odometer are each rounded.
ROUNDING_VAR_MM2 = 1.0 / 12.0


class FitError(ValueError):
    """Runs that cannot be fitted (no motion in them at all, or no samples)."""


@dataclass(frozen=True)
class Fitted:
    """One setting: its value, how well the runs pin it down, and whether they did.

    Attributes:
        name: The setting, in the fit's terms (``speed_2_mm_s``) or the profile's (``sensor_scale``).
        value: The fitted value, or the one it was left at.
        uncertainty: One standard deviation (0 where it was not fitted).
        unit: How the value is counted.
        fitted: Whether the runs set it.
        why: Why it was not fitted (empty when it was).
    """

    name: str
    value: float
    uncertainty: float
    unit: str
    fitted: bool = True
    why: str = ""

    @property
    def line(self) -> str:
        """One line: ``speed_2_mm_s  214.3 ± 0.4 mm/s``, or why it was left."""
        if not self.fitted:
            return f"{self.name:<20} {_shown(self.value):>9} {self.unit:<7} left at {_shown(self.value)}: {self.why}"
        return f"{self.name:<20} {_shown(self.value):>9} {self.unit:<7} ± {_shown(self.uncertainty)}"


@dataclass(frozen=True)
class Fit:
    """What a fit found.

    Attributes:
        params: The emulator's settings: the fitted ones, the rest as they were.
        values: Each setting the fit is about, in order (motion, then the sensor).
        rms_mm: The motion fit's RMS residual on the odometer, mm.
        rms_deg: Its RMS residual on the heading, degrees.
        samples: How many samples it was made from.
    """

    params: RobotParams
    values: tuple[Fitted, ...]
    rms_mm: float
    rms_deg: float
    samples: int

    def value(self, name: str) -> Fitted:
        """The setting called ``name``."""
        return next(v for v in self.values if v.name == name)

    def notes(self) -> dict[str, str]:
        """A profile file's comment for each setting: its uncertainty, or why it was left."""
        out: dict[str, str] = {}
        speeds = []
        for v in self.values:
            note = f"± {_shown(v.uncertainty)} {v.unit}".rstrip() if v.fitted else f"not fitted: {v.why}"
            if v.name.startswith("speed_"):
                speeds.append(
                    f"{v.name[6]}: {_shown(v.value)} mm/s " + (f"± {_shown(v.uncertainty)}" if v.fitted else "(left)")
                )
            else:
                out[v.name] = note
        out["speed_setting_v"] = "ground speeds " + ", ".join(speeds)
        return out


def _shown(value: float) -> str:
    if abs(value) < 1e-6:  # none, to the fit's rounding (a delay of 3e-11 s is none)
        return "0"
    if abs(value) >= 100:
        return f"{value:.1f}"
    if abs(value) < 1e-4:  # three digits, never as 1.5e-05 (a delay of a robot that acts at once)
        return f"{value:.{2 - math.floor(math.log10(abs(value)))}f}"
    return f"{value:.3g}"


# ---------------------------------------------------------------------- the model


def _evolve(
    s: float, v: float, target: float, h: float, r: float, tau: float, accel: float, rate: float
) -> tuple[float, float, float, float]:
    """The odometer, wheel speed, heading and turn left after ``tau`` seconds of the motion under way."""
    if r:
        turned = math.copysign(min(abs(r), rate * tau), r)
        h += turned
        r -= turned
    dv = target - v
    if dv:
        ramp = abs(dv) / accel
        if tau <= ramp:
            change = math.copysign(accel * tau, dv)
            s += v * tau + change * tau / 2.0
            v += change
        else:
            s += (v + target) / 2.0 * ramp + target * (tau - ramp)
            v = target
    else:
        s += v * tau
    return s, v, h, r


def predict(x: dict[str, float], sent: list[Sent], samples: list[Sample]) -> tuple[list[float], list[float]]:
    """The odometer (mm) and heading (degrees, unwrapped) the model says at each sample's time.

    The robot is taken to stand still at the first sample, where the odometer and heading are the sample's.
    """
    speeds = (x["speed_1_mm_s"], x["speed_2_mm_s"], x["speed_3_mm_s"], x["speed_4_mm_s"])
    accel, rate, delay = x["acceleration_mm_s2"], x["turn_rate_deg_s"], x["command_delay_s"]
    acts: list[tuple[float, Sent]] = []
    lead = x.get("speed_lead_s", 0.0)  # a move or a stop changes the speed this much before a turn would act
    for command in sent:  # in the order sent: one acting early does not overtake the one before it
        early = 0.0 if command.kind == "turn" else lead
        acts.append((max(command.time_s + delay - early, acts[-1][0] if acts else -math.inf), command))
    first = samples[0]
    s, v, target, h, r, now = first.odometer_mm, 0.0, 0.0, float(first.heading_deg), 0.0, first.time_s
    odometer: list[float] = []
    heading: list[float] = []
    i = 0
    for sample in samples:
        t = sample.time_s
        while i < len(acts) and acts[i][0] <= t:
            when, command = acts[i]
            if when > now:
                s, v, h, r = _evolve(s, v, target, h, r, when - now, accel, rate)
                now = when
            if command.kind == "move":
                target = math.copysign(speeds[abs(command.value) - 1], command.value)
                r = 0.0
            elif command.kind == "turn":
                target = v = 0.0
                r = float(command.value)
            else:
                target, r = 0.0, 0.0
            i += 1
        at = _evolve(s, v, target, h, r, t - now, accel, rate) if t > now else (s, v, h, r)
        odometer.append(at[0])
        heading.append(at[2])
    return odometer, heading


def pieces(recording: Recording) -> list[Recording]:
    """``recording`` cut where the robot stood still for ``REST_S`` before a move or turn was sent.

    A piece begins on a sample of that stand-still :data:`LEAD_IN_S` before the command (or its first);
    it holds the samples up to the next piece's first, and the commands sent in that time.
    """
    samples = recording.samples
    starts = [0]
    j = 0  # the last sample before the command
    for command in recording.sent:
        while j + 1 < len(samples) and samples[j + 1].time_s < command.time_s:
            j += 1
        if command.kind not in ("move", "turn") or j <= starts[-1] or samples[j].time_s >= command.time_s:
            continue
        here, k = samples[j], j
        while (
            k > 0
            and not samples[k - 1].moving
            and samples[k - 1].odometer_mm == here.odometer_mm
            and samples[k - 1].heading_deg == here.heading_deg
        ):
            k -= 1
        if not here.moving and here.time_s - samples[k].time_s >= REST_S:
            # from a sample still well before the command: the model may have it act early (its lateness, a
            # robot quicker than its link), and a piece cannot start after the command acted
            first = j
            while first > k and samples[first].time_s > command.time_s - LEAD_IN_S:
                first -= 1
            starts.append(first)
    out = []
    for a, b in zip(starts, [*starts[1:], len(samples)], strict=True):
        begin = samples[a].time_s if a else -math.inf
        end = samples[b].time_s if b < len(samples) else math.inf
        sent = [c for c in recording.sent if begin <= c.time_s < end]
        out.append(Recording(recording.label, sent, samples[a:b], recording.sensor_max_mm, recording.commands_timed))
    return out


def residuals(
    x: dict[str, float], recordings: list[Recording], lateness_s: Sequence[float] | None = None
) -> list[float]:
    """The model's misses at each sample: the odometer's in mm, then the heading's in degrees.

    Each recording is a run of its own: the model starts each one standing still at its first
    sample. ``lateness_s``, where given, holds how late each command acted beyond the common delay,
    the recordings' commands in order.
    """
    along: list[float] = []
    around: list[float] = []
    k = 0
    for recording in recordings:
        sent = recording.sent
        if lateness_s is not None:
            sent = [
                dataclasses.replace(c, time_s=c.time_s + late)
                for c, late in zip(sent, lateness_s[k : k + len(sent)], strict=True)
            ]
            k += len(sent)
        odometer, heading = predict(x, sent, recording.samples)
        along += [p - s.odometer_mm for p, s in zip(odometer, recording.samples, strict=True)]
        around += [(p - s.heading_deg + 180.0) % 360.0 - 180.0 for p, s in zip(heading, recording.samples, strict=True)]
    return along + around


def start_values(params: RobotParams) -> dict[str, float]:
    """The fit's settings as ``params`` has them (ground speeds from the wheel velocities)."""
    x = {f"speed_{k}_mm_s": params.speed_mm_s(k) for k in range(1, 5)}
    x |= {
        "acceleration_mm_s2": params.acceleration_mm_s2,
        "turn_rate_deg_s": params.turn_rate_deg_s,
        "command_delay_s": params.command_delay_s,
    }
    return x


def with_values(params: RobotParams, x: dict[str, float]) -> RobotParams:
    """``params`` with the fit's settings in it (ground speeds back to wheel velocities)."""
    circumference = params.wheel_circumference_mm
    speeds = tuple(x[f"speed_{k}_mm_s"] / circumference * 20.0 for k in range(1, 5))
    return dataclasses.replace(
        params,
        speed_setting_v=speeds,  # type: ignore[arg-type]
        acceleration_mm_s2=x["acceleration_mm_s2"],
        turn_rate_deg_s=x["turn_rate_deg_s"],
        command_delay_s=x["command_delay_s"],
    )


def _norm(values: list[float]) -> float:
    return math.sqrt(sum(v * v for v in values))


def _rms(values: list[float]) -> float:
    return math.sqrt(sum(v * v for v in values) / len(values)) if values else 0.0


def excited(x: dict[str, float], recording: list[Recording]) -> dict[str, bool]:
    """For each motion setting, whether the runs depend on it: moving it a step moves the prediction."""
    base = residuals(x, recording)
    out = {}
    for name in MOTION:
        step = PROBE_STEP.get(name, x[name] * PROBE_SHARE)
        moved = residuals(x | {name: x[name] + step}, recording)
        out[name] = _norm([a - b for a, b in zip(moved, base, strict=True)]) >= EXCITED_BELOW
    return out


def _unit(name: str) -> str:
    return {"acceleration_mm_s2": "mm/s²", "turn_rate_deg_s": "deg/s", "command_delay_s": "s"}.get(name, "mm/s")


def fit(recordings: Recording | list[Recording], params: RobotParams | None = None) -> Fit:
    """Fits ``params`` (the emulator's defaults when None) to one recording, or several runs together.

    Raises:
        FitError: a recording holds fewer than three samples, or none has any motion.
    """
    from scipy.optimize import least_squares

    params = params or RobotParams()
    recording = recordings if isinstance(recordings, list) else [recordings]
    for one in recording:
        if len(one.samples) < 3:
            raise FitError(f"{one.label}: {len(one.samples)} samples: a fit needs a run with motion in it")
    count = sum(len(one.samples) for one in recording)
    if count > MAX_SAMPLES:
        raise FitError(
            f"{recording[0].label}{' and the rest' if len(recording) > 1 else ''}: {count:,} samples; a fit takes at "
            f"most {MAX_SAMPLES:,} (a probe's are about 3,000; a quarter of an hour of runs at 20 Hz is 18,000): "
            "give fewer or shorter traces"
        )
    if not any(c.kind in ("move", "turn") for one in recording for c in one.sent):
        raise FitError(f"{recording[0].label}: the robot was never told to move or turn: nothing to fit")
    x0 = start_values(params) | {"speed_lead_s": params.step_s / 2.0}  # the emulator's, whose settings these are
    why: dict[str, str] = {}
    cut = [piece for one in recording for piece in pieces(one)]
    free = [name for name, yes in excited(x0, cut).items() if yes]
    for name in MOTION:
        if name not in free:
            why[name] = _not_excited_why(name)
    solution, sigma = dict(x0), dict.fromkeys(MOTION, 0.0)
    timed = [piece.commands_timed for piece in cut for _ in piece.sent]  # each command: is its lateness fitted?
    commands = sum(timed)
    lateness = [0.0] * len(timed)

    def each(late: Sequence[float]) -> list[float]:
        """Every command's lateness: those fitted, in order; none for the rest."""
        given = iter(late)
        return [float(next(given)) if fitted else 0.0 for fitted in timed]

    while free:
        low = [BOUNDS[n][0] for n in free] + [-LATENESS_S] * commands
        high = [BOUNDS[n][1] for n in free] + [LATENESS_S] * commands
        start = [min(max(x0[n], BOUNDS[n][0]), BOUNDS[n][1]) for n in free] + [0.0] * commands

        def misses(values: Sequence[float], names: list[str] = free) -> list[float]:
            settings, late = values[: len(names)], values[len(names) :]
            x = x0 | dict(zip(names, (float(v) for v in settings), strict=True))
            return residuals(x, cut, each(late)) + [LATENESS_MM_PER_S * v for v in late]

        sparsity = _sparsity(cut, len(free))
        result = least_squares(misses, start, bounds=(low, high), x_scale="jac", jac_sparsity=sparsity)
        found = dict(zip(free, (float(v) for v in result.x[: len(free)]), strict=True))
        lateness = each(result.x[len(free) :])
        spread = _spread(result, len(free))
        loose = [
            n
            for n, s in zip(free, spread, strict=True)
            if (s > LOOSE_DELAY_S if n == "command_delay_s" else s > LOOSE_SHARE * abs(found[n]))
        ]
        if not loose:
            solution |= found
            sigma |= dict(zip(free, spread, strict=True))
            break
        for n in loose:  # too loosely held: left where it was, and the rest fitted again without it
            share = spread[free.index(n)]
            held = (
                f"± {_shown(share)} s" if n == "command_delay_s" else f"± {100 * share / max(abs(found[n]), 1e-9):.0f}%"
            )
            why[n] = f"the runs hold too little of it to pin it down ({held})"
        free = [n for n in free if n not in loose]
    misses_all = residuals(solution, cut, lateness)
    count = sum(len(one.samples) for one in recording)
    values = [Fitted(n, solution[n], sigma[n], _unit(n), n not in why, why.get(n, "")) for n in MOTION]
    fitted = with_values(params, solution)
    sensor_values, fitted = _fit_sensor(recording, fitted)
    return Fit(fitted, (*values, *sensor_values), _rms(misses_all[:count]), _rms(misses_all[count:]), count)


def _not_excited_why(name: str) -> str:
    if name.startswith("speed_"):
        return f"the runs never drive at speed {name[6]}"
    if name == "turn_rate_deg_s":
        return "the runs never turn"
    if name == "acceleration_mm_s2":
        return "the runs never drive"
    return "the runs hold no motion command the robot was seen to act on"


def _sparsity(cut: list[Recording], settings: int) -> object:
    """Which misses each fitted value moves: a setting, all of them; a command's lateness, its piece's and its own.

    Only the commands of pieces whose commands are timed (a probe's) have a lateness of their own.
    """
    from scipy.sparse import lil_matrix

    samples = sum(len(piece.samples) for piece in cut)
    commands = sum(len(piece.sent) for piece in cut if piece.commands_timed)
    shape = lil_matrix((2 * samples + commands, settings + commands), dtype=int)
    shape[: 2 * samples, :settings] = 1
    row = column = 0
    for piece in cut:
        for _ in piece.sent if piece.commands_timed else ():
            shape[row : row + len(piece.samples), settings + column] = 1
            shape[samples + row : samples + row + len(piece.samples), settings + column] = 1
            shape[2 * samples + column, settings + column] = 1
            column += 1
        row += len(piece.samples)
    return shape


def _spread(result: object, count: int) -> list[float]:
    """One standard deviation of each fitted value, from the fit's Jacobian and what it left."""
    import numpy as np
    from scipy.sparse import csc_matrix
    from scipy.sparse.linalg import splu

    jac = csc_matrix(result.jac)  # type: ignore[attr-defined]
    left = np.asarray(result.fun)  # type: ignore[attr-defined]
    dof = max(len(left) - count, 1)
    variance = float(left @ left) / dof
    # The settings' block of the inverse of J'J, by its Schur complement: the commands' lateness (thousands of
    # them, each held by its own weight, so their block is invertible and sparse) is never made dense.
    settings, late = jac[:, :count].toarray(), jac[:, count:]
    normal = settings.T @ settings
    if late.shape[1]:
        cross = np.asarray(late.T @ settings)
        normal = normal - cross.T @ splu(csc_matrix(late.T @ late)).solve(cross)
    covariance = np.linalg.pinv(normal) * variance
    return [float(math.sqrt(max(covariance[i, i], 0.0))) for i in range(count)]


def _fit_sensor(recordings: list[Recording], params: RobotParams) -> tuple[list[Fitted], RobotParams]:
    """The front sensor's scale, offset and noise, from readings at known distances (or left, and why)."""
    points = [
        (s.gap_mm, s.front_mm)
        for one in recordings
        for s in one.samples
        if s.gap_mm is not None and 0 < s.front_mm < one.sensor_max_mm - SENSOR_EDGE_MM
    ]
    names = (("sensor_scale", ""), ("sensor_offset_mm", "mm"), ("sensor_noise_mm", "mm"))
    span = max(p[0] for p in points) - min(p[0] for p in points) if points else 0.0
    if len(points) < SENSOR_SAMPLES or span < SENSOR_SPAN_MM:
        known = [s.gap_mm for one in recordings for s in one.samples if s.gap_mm is not None]
        if points:
            why = f"{len(points)} readings over {span:.0f} mm: too few to fit"
        elif known:  # a probe's: it drove to the wall, and its sensor never read it
            why = (
                f"the sensor never read the wall, though the robot drove to {min(known):.0f} mm from where it was "
                "told the wall is: is the wall as far as --wall-mm says, and does the sensor face it?"
            )
        else:
            why = "the runs hold no reading at a known distance from a wall (a probe's do)"
        return [Fitted(n, getattr(params, n), 0.0, u, False, why) for n, u in names], params
    count = len(points)
    mean_gap = sum(g for g, _ in points) / count
    mean_reading = sum(r for _, r in points) / count
    sxx = sum((g - mean_gap) ** 2 for g, _ in points)
    scale = sum((g - mean_gap) * (r - mean_reading) for g, r in points) / sxx
    offset = mean_reading - scale * mean_gap
    left = [r - (scale * g + offset) for g, r in points]
    variance = sum(e * e for e in left) / max(count - 2, 1)
    scale_sd = math.sqrt(variance / sxx)
    offset_sd = math.sqrt(variance * (1.0 / count + mean_gap**2 / sxx))
    # what the readings scatter, less the rounding of the reading and of the odometer the distance comes from
    noise = math.sqrt(max(variance - 2 * ROUNDING_VAR_MM2, 0.0))
    noise_sd = math.sqrt(variance / (2 * max(count - 2, 1)))
    params = dataclasses.replace(params, sensor_scale=scale, sensor_offset_mm=offset, sensor_noise_mm=noise)
    return [
        Fitted("sensor_scale", scale, scale_sd, ""),
        Fitted("sensor_offset_mm", offset, offset_sd, "mm"),
        Fitted("sensor_noise_mm", noise, noise_sd, "mm"),
    ], params

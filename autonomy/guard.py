"""Which status packets to believe: the protocol has no checksum. No I/O, no clock.

A corrupted byte inside a status packet whose first and last bytes are intact cannot be seen
in the frame. :class:`StatusGuard` judges each packet against the robot's last believed state
on two tiers:

- **Impossible**: the odometer, heading or tilt moved further than a robot of this size can
  in the time since (:func:`status_jump`). The packet is refused, counted and read again.
- **Unexpected**: the flags (mode, auto, collision, moving) changed, or the odometer or
  heading strayed from where its recent speed would have taken it by more than a hard
  acceleration explains (:func:`status_surprise`). Such a packet may well be real (a
  collision, a start, a stop), so it is held and the next packet decides: a real change
  lasts, a flipped bit does not.

When two packets in a row agree with each other but not with the believed state, they are
right (the robot was moved or restarted, or a believed packet was a corrupted one that
looked possible): they are believed from then on, and :attr:`StatusGuard.rebased` counts it.
The link's first packet is held in the same way until a second one agrees.
"""

from __future__ import annotations

import enum

from autonomy.protocol import Status, heading_delta_deg, odometer_delta_mm

#: What a robot of this size cannot exceed between two status polls (twice the fastest
#: setting of the emulator, or more); a packet beyond it holds a corrupted byte.
PLAUSIBLE_SPEED_MM_S = 800.0
PLAUSIBLE_TURN_RATE_DEG_S = 180.0
PLAUSIBLE_TILT_RATE_DEG_S = 400.0
#: Allowed on top, for whole-unit readings and polls close together.
PLAUSIBLE_SLACK_MM = 10
PLAUSIBLE_SLACK_DEG = 3
PLAUSIBLE_TILT_SLACK_DEG = 10
#: Hard accelerations: a reading further from where its speed was taking it is read again.
EXPECTED_ACCELERATION_MM_S2 = 3000.0
EXPECTED_ANGULAR_ACCELERATION_DEG_S2 = 1500.0
EXPECTED_SLACK_MM = 4
EXPECTED_SLACK_DEG = 2
#: Speeds are taken from believed packets at least this far apart.
MIN_SPEED_SPAN_S = 0.01


class Verdict(enum.Enum):
    """What to do with a status packet: see :meth:`StatusGuard.judge`."""

    ACCEPT = "accept"
    READ_AGAIN = "read again"
    REFUSE = "refuse"


def status_jump(earlier: Status, earlier_s: float, later: Status, later_s: float) -> str:
    """Says how ``later`` cannot follow ``earlier`` in the time between them (empty: it can)."""
    elapsed_s = later_s - earlier_s
    if not elapsed_s > 0.0:  # max(0.0, elapsed_s): called on every poll, where a call to max() costs
        elapsed_s = 0.0
    moved_mm = abs(odometer_delta_mm(earlier.odometer_mm, later.odometer_mm))
    if moved_mm > PLAUSIBLE_SPEED_MM_S * elapsed_s + PLAUSIBLE_SLACK_MM:
        return f"odometer {earlier.odometer_mm} -> {later.odometer_mm} mm in {elapsed_s:.2f} s"
    turned_deg = abs(heading_delta_deg(earlier.heading_deg, later.heading_deg))
    if turned_deg > PLAUSIBLE_TURN_RATE_DEG_S * elapsed_s + PLAUSIBLE_SLACK_DEG:
        return f"heading {earlier.heading_deg} -> {later.heading_deg} deg in {elapsed_s:.2f} s"
    if abs(later.tilt_deg - earlier.tilt_deg) > PLAUSIBLE_TILT_RATE_DEG_S * elapsed_s + PLAUSIBLE_TILT_SLACK_DEG:
        return f"tilt {earlier.tilt_deg} -> {later.tilt_deg} deg in {elapsed_s:.2f} s"
    return ""


def status_surprise(before: Status, before_s: float, last: Status, last_s: float, packet: Status, now_s: float) -> bool:
    """True when ``packet`` strays from where the speed between ``before`` and ``last`` was taking it.

    The allowance is what a hard acceleration does over the time since, plus a little for
    whole-unit readings.
    """
    span_s, elapsed_s = last_s - before_s, now_s - last_s
    if not elapsed_s > 0.0:  # max(0.0, elapsed_s)
        elapsed_s = 0.0
    if span_s < MIN_SPEED_SPAN_S:
        return False
    reach_s2 = elapsed_s * (elapsed_s + span_s)
    speed_mm_s = odometer_delta_mm(before.odometer_mm, last.odometer_mm) / span_s
    moved_mm = odometer_delta_mm(last.odometer_mm, packet.odometer_mm)
    if abs(moved_mm - speed_mm_s * elapsed_s) > EXPECTED_ACCELERATION_MM_S2 * reach_s2 + EXPECTED_SLACK_MM:
        return True
    rate_deg_s = heading_delta_deg(before.heading_deg, last.heading_deg) / span_s
    turned_deg = heading_delta_deg(last.heading_deg, packet.heading_deg)
    return (
        abs(turned_deg - rate_deg_s * elapsed_s) > EXPECTED_ANGULAR_ACCELERATION_DEG_S2 * reach_s2 + EXPECTED_SLACK_DEG
    )


def _same_flags(a: Status, b: Status) -> bool:
    """Whether two packets hold the same mode and flags (field by field: asked of every packet)."""
    return a.mode == b.mode and a.auto_mode == b.auto_mode and a.collided == b.collided and a.moving == b.moving


class StatusGuard:
    """Decides which status packets to believe (see the module's description).

    Attributes:
        trusted: The last believed packet (None before the first).
        rebased: How many times two agreeing packets replaced the believed state.
    """

    def __init__(self) -> None:
        self.trusted: Status | None = None
        self.rebased = 0
        self._trusted_s = 0.0
        self._before: Status | None = None  # the believed packet before ``trusted``, for its speed
        self._before_s = 0.0
        self._held: Status | None = None
        self._held_s = 0.0
        self._held_refused = False

    def judge(self, packet: Status, now_s: float) -> tuple[Verdict, str]:
        """Returns what to do with ``packet``, read at ``now_s``, and why.

        The reason comes with a refusal, and with an acceptance that drops the packet held
        before (a change the next packet did not show), so that each can be counted.
        """
        held, held_refused, self._held = self._held, self._held_refused, None
        if held is not None and _same_flags(held, packet) and not status_jump(held, self._held_s, packet, now_s):
            if held_refused and self.trusted is not None:  # two agree: the believed state was the wrong one
                self.rebased += 1
                self._before = None
            return self._believe(packet, now_s)
        trusted = self.trusted
        if trusted is None:  # nothing believed yet: a packet that disagrees with the one held is refused
            why = status_jump(held, self._held_s, packet, now_s) if held is not None else ""
            if held is not None and not why and not _same_flags(held, packet):
                why = "flags that differ from the packet before"
            return self._hold(packet, now_s, why)
        why = status_jump(trusted, self._trusted_s, packet, now_s)
        if why:
            return self._hold(packet, now_s, why)
        surprise = not _same_flags(packet, trusted) or (
            self._before is not None
            and status_surprise(self._before, self._before_s, trusted, self._trusted_s, packet, now_s)
        )
        if surprise:
            return self._hold(packet, now_s, "")
        dropped = held is not None and not held_refused
        return self._believe(packet, now_s, "a change the next packet did not show" if dropped else "")

    def _hold(self, packet: Status, now_s: float, why: str) -> tuple[Verdict, str]:
        self._held, self._held_s, self._held_refused = packet, now_s, bool(why)
        return (Verdict.REFUSE, why) if why else (Verdict.READ_AGAIN, "")

    def _believe(self, packet: Status, now_s: float, dropped: str = "") -> tuple[Verdict, str]:
        if self.trusted is not None and now_s - self._trusted_s >= MIN_SPEED_SPAN_S:
            self._before, self._before_s = self.trusted, self._trusted_s
        self.trusted, self._trusted_s = packet, now_s
        return Verdict.ACCEPT, dropped

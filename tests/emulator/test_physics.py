"""The emulator's physics, checked against geometry and against the protocol."""

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from autonomy.client import Client
from autonomy.emulator import RobotParams, load_world
from autonomy.emulator.robot import Robot
from autonomy.emulator.world import SENSOR_CONE_DEG, SENSOR_RAYS, Circle, Pose, World
from autonomy.protocol import odometer_delta_mm

RADIUS = RobotParams().body_radius_mm


def emu_client(query: str = "") -> Client:
    return Client.open(f"emu://?time=virtual{'&' if query else ''}{query}")


def wait_until_still(client: Client, limit_s: float = 20.0):
    start = client.clock.now()
    while client.clock.now() - start < limit_s:
        client.clock.sleep(0.05)
        status = client.status()
        if not status.moving:
            return status, client.clock.now() - start
    raise AssertionError("the robot never stopped")


def marched_gap(world: World, x: float, y: float, heading_deg: float, step: float = 0.25) -> float:
    """Walks along the ray in small steps until it leaves free space: independent of the ray casts."""
    dx, dy = math.cos(math.radians(heading_deg)), math.sin(math.radians(heading_deg))
    t = 0.0
    while t < 400:
        px, py = x + dx * t, y + dy * t
        if world.clearance(px, py) <= 0:
            return t
        t += step
    return math.inf


# ----------------------------------------------------------------------------- turning


@pytest.mark.parametrize(("angle", "expected"), [(90, 90), (-90, 270), (45, 45), (450, 90), (-720, 0), (181, 181)])
def test_turns_end_within_3_degrees(angle, expected):
    client = emu_client()
    client.turn(angle)
    status, took_s = wait_until_still(client)
    error = (status.heading_deg - expected + 180) % 360 - 180
    assert abs(error) <= 3
    assert took_s == pytest.approx(abs(angle) / RobotParams().turn_rate_deg_s, abs=0.1)
    assert status.odometer_mm == 0  # turning in place moves no distance


def test_heading_grows_on_left_turns():
    client = emu_client()
    client.turn(30)
    client.clock.sleep(0.2)
    assert 0 < client.status().heading_deg < 30
    assert client.status().mode == 2  # turning


# ----------------------------------------------------------------------------- driving


def test_speed_settings_match_wheel_geometry():
    params = RobotParams()
    client = emu_client("world=empty")
    client.move(2)
    client.clock.sleep(1.0)  # past the acceleration
    assert client.velocity() == 20  # V units: 20 = one wheel revolution per second
    before = client.status().odometer_mm
    client.clock.sleep(2.0)
    travelled = odometer_delta_mm(before, client.status().odometer_mm)
    assert travelled == pytest.approx(2 * math.pi * params.wheel_diameter_mm, abs=2)


def test_backward_odometer_counts_down_and_wraps():
    client = emu_client("world=empty")
    client.move(1, backward=True)
    client.clock.sleep(1.0)
    status = client.status()
    assert status.odometer_mm > 60000  # wrapped below zero
    assert odometer_delta_mm(0, status.odometer_mm) < -50
    assert client.velocity() < 0


def test_stop_slows_down_then_stands_still():
    client = emu_client("world=empty")
    client.move(4)
    client.clock.sleep(1.0)
    client.stop()
    status = client.status()
    assert status.mode == 0 and status.moving  # commanded to stop, still rolling
    status, took_s = wait_until_still(client)
    assert took_s < 0.5


def test_driving_at_a_wall_sets_collision_and_stops():
    client = emu_client("world=box")
    robot = client.port.emulator.robot
    client.move(3)
    hit = None
    for _ in range(200):
        client.clock.sleep(0.05)
        status = client.status()
        if status.collided:
            hit = status
            break
    assert hit is not None, "never collided"
    assert not hit.moving and hit.mode == 0 and hit.front_distance_mm == 0
    assert robot.x_mm == pytest.approx(2000 - RADIUS, abs=0.5)  # touching the east wall
    assert len(robot.impacts) == 1
    impact_s = robot.impacts[0].time_s
    client.clock.sleep(impact_s + 0.45 - client.port.emulator.now_s())
    assert client.status().collided  # held for at least 0.5 s
    client.clock.sleep(0.1)
    assert not client.status().collided
    client.move(1)  # pushing on: another impact, the flag comes back
    client.clock.sleep(0.05)
    assert client.status().collided and len(robot.impacts) == 2


def test_impact_with_a_post_stops_the_robot_touching_it():
    world = World("post", 3000, 3000, Pose(500, 500, 45.0), (Circle(1200, 1200, 100),))
    robot = Robot(world)
    robot.move(2)
    robot.advance_to(10.0)
    assert robot.impacts and robot.speed_mm_s == 0
    centre_gap = math.hypot(robot.x_mm - 1200, robot.y_mm - 1200)
    assert centre_gap == pytest.approx(100 + RADIUS, abs=0.5)


def test_tilt_leans_into_acceleration_and_kicks_on_impact():
    client = emu_client("world=box")
    client.move(4)
    client.clock.sleep(0.1)
    assert client.tilt_deg() > 0  # leaning forward while speeding up
    client.clock.sleep(1.0)
    assert abs(client.tilt_deg()) <= 1  # upright while cruising
    status = client.status()
    while not status.collided and client.clock.now() < 10:
        client.clock.sleep(0.01)
        status = client.status()
    assert status.collided and status.tilt_deg > 5  # the impact throws it forward


# ----------------------------------------------------------------------------- sensor


@pytest.mark.parametrize(
    ("x", "heading", "gap"), [(1700, 0, 240), (1800, 0, 140), (1935, 0, 5), (250, 180, 190), (1000, 0, 255)]
)
def test_sensor_reads_the_true_gap_to_a_wall(x, heading, gap):
    world = World("box", 2000, 2000, Pose(x, 1000, heading))
    assert Robot(world).front_distance_mm() == pytest.approx(gap, abs=2)


def test_sensor_sees_a_post_through_the_protocol():
    world = World("post", 3000, 3000, Pose(500, 500, 0.0), (Circle(800, 500, 50),))
    client = Client.open("emu://?time=virtual")
    client.port.emulator.robot = Robot(world)
    client.port.emulator.firmware.robot = client.port.emulator.robot
    assert client.front_distance_mm() == 800 - 50 - (500 + RADIUS)


obstacles = load_world("obstacles")


@settings(max_examples=150, deadline=None)
@given(
    st.floats(RADIUS, obstacles.width_mm - RADIUS),
    st.floats(RADIUS, obstacles.height_mm - RADIUS),
    st.floats(0, 360, exclude_max=True),
)
def test_sensor_agrees_with_a_ray_march_over_its_cone(x, y, heading):
    robot = Robot(World("o", obstacles.width_mm, obstacles.height_mm, Pose(x, y, heading), obstacles.obstacles))
    if not obstacles.circle_fits(x, y, RADIUS):
        return  # a start pose inside an obstacle is not a place the robot can be
    sx, sy = x + RADIUS * math.cos(math.radians(heading)), y + RADIUS * math.sin(math.radians(heading))
    half = SENSOR_CONE_DEG / 2
    rays = [heading - half + k * SENSOR_CONE_DEG / (SENSOR_RAYS - 1) for k in range(SENSOR_RAYS)]
    expected = min(255.0, *(marched_gap(obstacles, sx, sy, ray) for ray in rays))
    assert abs(robot.front_distance_mm() - expected) <= 2


def test_the_cone_sees_a_wall_met_at_a_shallow_angle_that_the_centre_ray_misses():
    # driving east 20 mm from the north wall, turned 8 degrees towards it: the heading's own ray
    # meets the wall about 515 mm ahead (out of range), the cone's edge at about 205 mm
    world = World("hall", 4000, 1000, Pose(500, 920, 8.0))
    robot = Robot(world)
    front_y = 920 + RADIUS * math.sin(math.radians(8))
    centre_ray_mm = (1000 - front_y) / math.sin(math.radians(8))
    edge_ray_mm = (1000 - front_y) / math.sin(math.radians(8 + SENSOR_CONE_DEG / 2))
    assert centre_ray_mm > 255
    assert robot.front_distance_mm() == pytest.approx(edge_ray_mm, abs=1)
    single_ray = Robot(world, RobotParams(sensor_cone_deg=0))
    assert single_ray.front_distance_mm() == 255


# ----------------------------------------------------------------------------- servos, battery, modes


def test_servos_move_at_their_speed_and_step_relative():
    client = emu_client()
    robot = client.port.emulator.robot
    client.servo_to(0, 90)
    client.clock.sleep(0.375)
    client.port.emulator.advance()  # the emulator catches up lazily; reading robot state directly needs this
    assert robot.servo_deg[0] == pytest.approx(45, abs=1)  # 120 deg/s
    client.clock.sleep(0.5)
    client.port.emulator.advance()
    assert robot.servo_deg[0] == pytest.approx(90)
    client.servo_by(0, -5)
    client.servo_by(2, 9)
    client.clock.sleep(0.5)
    client.port.emulator.advance()
    assert robot.servo_deg[0] == pytest.approx(85) and robot.servo_deg[2] == pytest.approx(9)


def test_battery_drains_faster_when_moving():
    idle, driving = Robot(load_world("empty")), Robot(load_world("empty"))
    driving.move(2)
    idle.advance_to(30.0)
    driving.advance_to(30.0)  # 6.4 m: far from any wall of the 20 m hall
    params = RobotParams()
    assert not driving.impacts
    assert idle.battery == pytest.approx(params.battery_start - 30 * params.battery_idle_drain_per_s, abs=0.01)
    assert driving.battery == pytest.approx(idle.battery - 30 * params.battery_motion_drain_per_s, abs=0.01)


def test_low_battery_is_unhealthy_and_flat_battery_refuses_motion():
    client = emu_client("battery=30")
    assert client.battery() == 30 and client.healthy() is False
    flat = emu_client("battery=5")
    with pytest.raises(Exception, match="refused F"):
        flat.move(1)


def test_manual_mode_refuses_motion_but_answers_the_rest():
    client = emu_client("mode=manual")
    assert client.status().auto_mode is False
    for call in (
        lambda: client.move(1),
        lambda: client.turn(5),
        lambda: client.servo_to(0, 1),
        lambda: client.servo_by(0, 1),
    ):
        with pytest.raises(Exception, match="refused"):
            call()
    client.beep((1, 2, 3), 1)
    client.stop()
    client.port.emulator.set_auto_mode(True)
    client.move(1)
    assert client.status().mode == 1


def test_fallen_robot_reports_it_and_refuses_motion():
    client = emu_client()
    client.port.emulator.robot.knock_over()
    status = client.status()
    assert status.mode == 3 and status.tilt_deg == 90
    assert client.healthy() is False
    with pytest.raises(Exception, match="refused"):
        client.move(1)


def test_physics_does_not_depend_on_how_often_it_is_asked():
    def final_pose(poll_s: float):
        client = emu_client("world=obstacles")
        client.move(3)
        while client.clock.now() < 3.0:
            client.clock.sleep(poll_s)
            client.status()
        return client.port.emulator.robot.pose

    often, seldom = final_pose(0.01), final_pose(0.37)
    # A steady drive is moved several steps at once, so positions agree to within rounding
    assert often.heading_deg == seldom.heading_deg
    assert often.x_mm == pytest.approx(seldom.x_mm, abs=1e-9) and often.y_mm == pytest.approx(seldom.y_mm, abs=1e-9)


commands = st.one_of(
    st.tuples(st.just("move"), st.integers(1, 4), st.booleans()),
    st.tuples(st.just("turn"), st.integers(-180, 180)),
    st.tuples(st.just("stop")),
    st.tuples(st.just("servo_to"), st.integers(0, 2), st.integers(-99, 99)),
    st.tuples(st.just("knock_over")),
    st.tuples(st.just("stand_up")),
)


@settings(max_examples=150, deadline=None)
@given(
    st.sampled_from(["obstacles", "box", "corridor"]),
    st.lists(st.tuples(commands, st.floats(0.0, 3.0)), min_size=1, max_size=12),
)
def test_steady_driving_turning_and_standing_are_stepped_as_step_by_step(name, script):
    # The cruise takes the steps of a straight drive at once, and _stand those of a robot turning in
    # place or standing one by one; without them every step is _step's. Turning and standing come
    # to the same numbers; a drive moved several steps at once, to the same within rounding.
    world = load_world(name)
    cruising, stepping = Robot(world), Robot(world)
    stepping._cruise = stepping._stand = lambda dt, until_s: 0  # type: ignore[method-assign]
    driven = any(command == "move" for (command, *_), _ in script)
    for (command, *arguments), seconds in script:
        for robot in (cruising, stepping):
            getattr(robot, command)(*arguments)
            robot.advance_to(robot.time_s + seconds)
        assert cruising.time_s == stepping.time_s  # every step where stepping puts it, always
        if driven:  # what each measured last, and where, may differ by the rounding of a position
            state = {key: value for key, value in vars(cruising).items() if key not in ("_rng", "_cruise", "_stand")}
            other = {key: value for key, value in vars(stepping).items() if key not in ("_rng", "_cruise", "_stand")}
            del state["_free_at"], state["_seen"], other["_free_at"], other["_seen"]
            assert _close(state, other)
        else:  # turning in place and standing: number for number
            assert _same_state(cruising, stepping)
    assert _close(cruising.impacts, stepping.impacts)


def _same_state(a: Robot, b: Robot) -> bool:
    """Every field the same number (NaN in the sensor's cache where nothing was seen yet counts as the same)."""
    left_out = ("_rng", "_cruise", "_stand", "_seen")
    return {k: v for k, v in vars(a).items() if k not in left_out} == {
        k: v for k, v in vars(b).items() if k not in left_out
    } and repr(a._seen) == repr(b._seen)


def _close(a: object, b: object) -> bool:
    """Equal, floats to within rounding (1e-6 mm, degrees, seconds or battery units), looking inside containers."""
    if isinstance(a, float) and isinstance(b, float):
        return a == pytest.approx(b, rel=1e-12, abs=1e-6)
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_close(a[key], b[key]) for key in a)
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        return type(a) is type(b) and len(a) == len(b) and all(map(_close, a, b))
    if hasattr(a, "__dataclass_fields__") and type(a) is type(b):
        return _close(vars(a), vars(b))
    return a == b


@settings(max_examples=100, deadline=None)
@given(
    st.sampled_from(["obstacles", "box", "corridor"]),
    st.lists(st.tuples(commands, st.floats(0.0, 3.0)), min_size=1, max_size=12),
)
def test_the_robot_s_own_trail_is_its_path_between_any_two_moments(name, script):
    """Each pose the robot passes through lies on the trail's segment for that moment, so a judge reading the
    trail sees every place the robot was, however seldom anything asked; and it last moved at ``moved_s``."""
    robot = Robot(load_world(name))
    seen = [(robot.time_s, robot.pose)]
    last_move_s = 0.0
    for (command, *arguments), seconds in script:
        getattr(robot, command)(*arguments)
        until_s = robot.time_s + seconds
        while robot.time_s + robot.params.step_s <= until_s + 1e-12:
            before = robot.pose
            robot.advance_to(robot.time_s + robot.params.step_s)
            moved = abs(robot.x_mm - before.x_mm) > 1e-6 or abs(robot.y_mm - before.y_mm) > 1e-6  # not pushing
            if moved or robot.heading_deg != before.heading_deg:
                last_move_s = robot.time_s
            seen.append((robot.time_s, robot.pose))
    robot.stop()  # marks where it is now
    trail = robot.trail
    assert trail[0] == (0.0, seen[0][1]) and trail[-1][1] == robot.pose
    assert all(a[0] <= b[0] for a, b in zip(trail, trail[1:], strict=False))  # in time order
    for time_s, pose in seen:
        # the segment between the last trail point at or before this moment and the next one
        index = max(i for i, (t, _) in enumerate(trail) if t <= time_s + 1e-9)
        a = trail[index][1]
        b = trail[min(index + 1, len(trail) - 1)][1]
        dx, dy = b.x_mm - a.x_mm, b.y_mm - a.y_mm
        length2 = dx * dx + dy * dy
        t = (
            0.0
            if length2 == 0
            else max(0.0, min(1.0, ((pose.x_mm - a.x_mm) * dx + (pose.y_mm - a.y_mm) * dy) / length2))
        )
        assert math.hypot(pose.x_mm - (a.x_mm + dx * t), pose.y_mm - (a.y_mm + dy * t)) < 1e-6
    assert robot.moved_s == pytest.approx(last_move_s, abs=1e-9) or (robot.moved_s == 0.0 and last_move_s == 0.0)


def test_a_straight_drive_is_kept_as_its_two_ends_and_a_stay_in_one_place_as_two_points():
    robot = Robot(load_world("empty"))
    start = robot.pose
    for _ in range(20):  # the same command again and again: the drive goes on
        robot.move(2)
        robot.advance_to(robot.time_s + 0.1)
    robot.stop()
    robot.advance_to(robot.time_s + 3.0)  # a pause
    robot.turn(90)
    robot.advance_to(robot.time_s + 2.0)
    robot.turn(-45)  # another turn where it stands
    robot.advance_to(robot.time_s + 2.0)
    robot.move(2)
    robot.advance_to(robot.time_s + 0.5)
    robot.stop()
    times = [time_s for time_s, _ in robot.trail]
    points = [pose for _, pose in robot.trail]
    assert points[0] == start and len(points) == 4  # the start, came to the corner, left it, the end
    assert points[1].y_mm == start.y_mm and points[1].x_mm > start.x_mm + 300  # the first drive went east
    assert points[1].heading_deg == start.heading_deg and points[2].heading_deg == pytest.approx(45)  # the net turn
    assert (points[1].x_mm, points[1].y_mm) == (points[2].x_mm, points[2].y_mm)
    assert times[1] == pytest.approx(2.0 + 0.2, abs=0.2) and times[2] == pytest.approx(times[1] + 7.0, abs=0.3)
    assert points[3].x_mm > points[2].x_mm and points[3].y_mm > points[2].y_mm  # then north-east


# ----------------------------------------------------------------------------- a robot's own settings


def test_a_delayed_robot_acts_on_a_move_a_turn_and_a_stop_command_delay_s_after_each():
    params = RobotParams(command_delay_s=0.1, acceleration_mm_s2=1000.0)
    robot = Robot(World("box", 4000, 2000, Pose(1000, 1000, 0)), params)
    robot.move(2)
    robot.advance_to(0.095)
    assert robot.odometer_mm == 0.0 and robot.speed_mm_s == 0.0  # not yet
    robot.advance_to(0.3)
    # 0.2 s of speeding up at 1000 mm/s² from the moment it acted: a t² / 2 = 20 mm
    assert robot.odometer_mm == pytest.approx(0.5 * 1000.0 * 0.2**2, abs=0.5)
    speed = params.speed_mm_s(2)
    robot.advance_to(1.0)
    robot.stop()
    robot.advance_to(1.095)
    assert robot.speed_mm_s == pytest.approx(speed)  # the stop has not acted yet
    robot.advance_to(3.0)
    assert robot.speed_mm_s == 0.0
    # speeding up and slowing down each cost half the ramp's distance: the drive is (1.0 - 0.0) s at speed
    assert robot.odometer_mm == pytest.approx(speed * 1.0, abs=1.0)
    robot.turn(90)
    robot.advance_to(3.095)
    assert robot.heading_deg == pytest.approx(0.0)
    robot.advance_to(3.1 + 90 / params.turn_rate_deg_s + 0.05)
    assert robot.heading_deg == pytest.approx(90.0, abs=1.0)


def test_a_halt_acts_at_once_and_drops_the_commands_not_yet_acted_on():
    robot = Robot(World("box", 4000, 2000, Pose(1000, 1000, 0)), RobotParams(command_delay_s=0.2))
    robot.move(4)
    robot.advance_to(0.1)
    robot.halt()  # the remote took over before the move acted
    robot.advance_to(2.0)
    assert robot.odometer_mm == 0.0 and robot.speed_mm_s == 0.0
    robot.move(4)
    robot.advance_to(2.5)
    assert robot.speed_mm_s > 0.0
    robot.knock_over()
    assert robot.speed_mm_s == 0.0 and robot.target_speed_mm_s == 0.0


@pytest.mark.parametrize(("x", "gap"), [(1700, 240), (1800, 140), (1900, 40)])
def test_a_scaled_and_offset_sensor_reads_scale_times_the_gap_plus_the_offset(x, gap):
    world = World("box", 2000, 2000, Pose(x, 1000, 0))
    exact = Robot(world).front_distance_mm()
    assert exact == pytest.approx(gap, abs=2)
    skewed = Robot(world, RobotParams(sensor_scale=0.9, sensor_offset_mm=12.0)).front_distance_mm()
    assert skewed == pytest.approx(min(0.9 * exact + 12.0, 255), abs=1)


@pytest.mark.parametrize("moving", [False, True])
def test_the_robot_keeps_up_with_the_clock_over_an_hour_of_ticks(moving):
    """The robot's time is a sum of 5 ms steps, which rounding takes a little short of the clock's: it must still
    stand on the clock's tick, not a step behind it (its status 5 ms old, its commands acted on 5 ms early), as it
    did from 13 s on."""
    robot = Robot(load_world("empty" if moving else "box"), RobotParams())
    if moving:  # a slow drive in an empty world, stopped and driven again now and then
        robot.move(1)
    behind = []
    for tick in range(1, 72_001):  # an hour of 20 Hz ticks
        now_s = tick * 0.05
        if moving and tick % 200 == 0:
            robot.stop() if tick % 400 else robot.move(1, backward=bool(tick % 800))
        robot.advance_to(now_s)
        if now_s - robot.time_s > robot.params.step_s / 2:
            behind.append(now_s)
    assert behind == []

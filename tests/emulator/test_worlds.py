"""World files: the shipped ones load, bad ones are explained."""

import math

import pytest

from autonomy.emulator import Box, Circle, WorldError, load_world
from autonomy.emulator.world import SHIPPED


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_worlds_load_with_a_free_start(name):
    world = load_world(name)
    start = world.start
    assert world.circle_fits(start.x_mm, start.y_mm, 60)


def test_world_from_a_file(tmp_path):
    path = tmp_path / "lab.yaml"
    path.write_text(
        "arena_mm: [1000, 500]\nstart: {x_mm: 100, y_mm: 250}\nobstacles:\n"
        "  - box: {from_mm: [600, 0], to_mm: [500, 100]}\n  - circle: {center_mm: [800, 400], radius_mm: 30}\n"
    )
    world = load_world(path)
    assert world.obstacles == (Box(500, 0, 600, 100), Circle(800, 400, 30))
    assert world.start.heading_deg == 0


def test_ray_casts_against_boxes_and_circles():
    world = load_world("corridor")
    assert world.ray_distance(200, 300, 0) == pytest.approx(3800)  # the east wall
    assert world.ray_distance(2000, 300, 90) == pytest.approx(150 - 60)  # up to the post's edge
    assert world.ray_distance(2900, 100, 0) == pytest.approx(100)  # the box's west face
    assert world.ray_distance(2000, 300, 45) == pytest.approx(300 / math.sin(math.radians(45)), rel=1e-6)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("arena_mm: 5", "arena_mm must be a pair"),
        ("arena_mm: [0, 10]", "must be positive"),
        ("arena_mm: [10, 10]\nobstacles: [{wall: {}}]", "unknown obstacle 'wall'"),
        ("arena_mm: [10, 10]\nstart: {x_mm: east}", "'x_mm' must be a number"),
        ("arena_mm: [10, 10\n", "not valid YAML"),
    ],
)
def test_bad_world_files(tmp_path, text, message):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(WorldError, match=message):
        load_world(path)


def test_unknown_world_name_lists_the_shipped_ones():
    with pytest.raises(WorldError, match="box, empty, corridor, obstacles"):
        load_world("mars")

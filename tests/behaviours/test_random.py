"""The ``random`` composite: one child picked each time it starts, the same picks under the same seed."""

from __future__ import annotations

from pathlib import Path

from autonomy.testing import run_mission

WALK = """\
mission: random walk
world: empty
tree:
  repeat:
    times: 8
    do:
      random:
        name: pick one
{seed}        children:
          - turn: {{left: 90}}
          - turn: {{right: 90}}
          - sequence: [{{wait: {{seconds: 0.5}}}}, {{beep: {{volume: 2}}}}]
"""


def picks(path: Path, seed: int) -> list[str]:
    """The children the random node picked, in order, as its feedback says them."""
    run = run_mission(path, seed=seed)
    assert run.outcome == "succeeded", run.summary
    said: list[str] = []
    for message in run.feedback("pick one"):
        if message and (not said or said[-1] != message):
            said.append(message)
    return [message.split("'")[1] for message in said]


def test_the_same_seed_picks_the_same_children_and_another_seed_others(tmp_path):
    path = tmp_path / "walk.yaml"
    path.write_text(WALK.format(seed=""))
    first = picks(path, 1)
    assert len(first) == 8 and set(first) <= {"turn left 90 deg", "turn right 90 deg", "sequence"}
    assert picks(path, 1) == first  # replayed: the same picks, in the same order
    others = [picks(path, seed) for seed in (2, 3, 4, 5)]
    assert any(other != first for other in others)  # eight picks of three: four other seeds cannot all agree
    assert {p for other in [first, *others] for p in other} == {"turn left 90 deg", "turn right 90 deg", "sequence"}


def test_a_seed_given_to_the_node_picks_the_same_whatever_the_run_s_seed(tmp_path):
    path = tmp_path / "walk.yaml"
    path.write_text(WALK.format(seed="        seed: 7\n"))
    assert picks(path, 1) == picks(path, 2) == picks(path, 3)


def test_a_pick_runs_to_its_end_before_the_next_pick(tmp_path):
    path = tmp_path / "walk.yaml"
    path.write_text(WALK.format(seed=""))
    run = run_mission(path, seed=1)
    picked = picks(path, 1)
    beeps = [n.id for n in run.header.nodes if n.type == "beep"]
    sounded = sum(
        1 for tick in run.ticks for node, state in tick.nodes.items() if node in beeps and state.status == "SUCCESS"
    )
    # eight picks for eight repeats, and each wait of half a second (many ticks) ran on to its beep
    assert len(picked) == 8 and sounded == picked.count("sequence") > 0


def test_random_goes_to_behaviortree_cpp_xml_and_back(tmp_path):
    from autonomy.mission import load_mission
    from autonomy.mission.btcpp import export_xml

    path = tmp_path / "walk.yaml"
    path.write_text(WALK.format(seed="        seed: 7\n"))
    xml = export_xml(load_mission(path))
    assert '<random name="pick one" seed="7">' in xml and '<Control ID="random">' in xml
    (tmp_path / "walk.xml").write_text(xml)
    back = load_mission(tmp_path / "walk.xml")
    assert back.tree.children[0].type.name == "random" and back.tree.children[0].args["seed"] == 7
    assert export_xml(back) == xml

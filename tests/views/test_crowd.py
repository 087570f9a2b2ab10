"""A run under a crowd of clients that never read: its memory stays bounded and it ends by itself (loopback only)."""

from __future__ import annotations

from tests.crowd import GrootCrowd, PeakMemory, Run, big_mission, non_readers


def test_200_groot2_and_60_view_clients_that_never_read_leave_the_run_under_300_mb_and_it_ends(tmp_path):
    mission = big_mission(tmp_path / "big.yaml", drive_s=4.0)  # 1,605 nodes: the tree's XML is 190 KB
    run = Run(str(mission), "--view", "--view-port", "0", "--groot", "--groot-port", "0", "--quiet")
    start_mb = run.start["VmRSS"]
    groot = GrootCrowd(run.groot_port, 200)
    readers = non_readers(run.view_port, 60)
    peak = PeakMemory(run.process.pid)
    try:
        ended, code, said = run.finish(timeout_s=60)
    finally:
        peak.close()
        groot.close()
        for conn in readers:
            conn.close()
    assert groot.sent > 5_000  # they asked, all along
    assert ended, said  # the run ended by itself, its robot stopped
    assert code == 0, said  # it succeeded (its view then ended by Ctrl-C)
    assert peak.peak_mb - start_mb < 300, f"{start_mb} MB at the start, {peak.peak_mb} MB at the peak"
    assert "Traceback" not in said, said

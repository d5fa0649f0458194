"""ieslam.simulate's table, and Ctrl-C during a run."""
import os
import signal
import threading
import time

import pytest

import ieslam


def test_simulate_table():
    study = ieslam.simulate(runs=1, seed=2, buffers=[2], poses=20)
    table = study["table"]
    assert [row["selector"] for row in table] == ["all", "info"]
    assert table[1]["buffer"] == 2
    for row in table:
        assert row["frames_total"] == 20
        assert 0 < row["frames_used"] <= 20 and row["ate_rmse_m"] >= 0.0
    assert study["runs_done"] == 1 and "|" in study["markdown"]
    with pytest.raises(ieslam.ConfigError, match="trajectory"):
        ieslam.simulate(trajectory="circle")


def test_ctrl_c_interrupts_a_run(seven_scenes):
    # SIGINT to this process while the run is under way: the run stops at its next frame
    # and the call raises KeyboardInterrupt.
    timer = threading.Timer(1.0, os.kill, (os.getpid(), signal.SIGINT))
    start = time.monotonic()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            ieslam.run(seven_scenes, {"write_map": False}, threads=1)
    finally:
        timer.cancel()
    # The whole sequence takes far longer than this.
    assert time.monotonic() - start < 10.0

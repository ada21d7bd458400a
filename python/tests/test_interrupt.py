"""Ctrl-C interrupts a long call within about a second (the library checks a stop request
between grid nodes and in the detector), not only when the call returns."""

import os
import signal
import threading
import time

import pytest

import stiction


@pytest.fixture(scope="module")
def long_loop():
    return stiction.simulate(valve={"kind": "kano", "S": 4.0, "J": 1.0}, samples=60000, seed=4)


def _run(call, loop):
    if call == "detect":
        return stiction.detect(loop)
    return stiction.quantify(loop, linear="armax", orders="4,4,4")


@pytest.mark.parametrize("call", ["detect", "quantify"])
def test_ctrl_c_interrupts_a_long_call(long_loop, call):
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signals reach the main thread only")
    # the signal comes a third of the way into the call, as long as the call takes on this
    # machine (at most a second in), so that the call is still running when it arrives
    started = time.monotonic()
    _run(call, long_loop)
    after = min(1.0, (time.monotonic() - started) / 3)
    timer = threading.Timer(after, lambda: os.kill(os.getpid(), signal.SIGINT))
    started = time.monotonic()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            _run(call, long_loop)
            # the call must last past the signal for the test to mean anything
            pytest.fail(f"{call} returned before the signal")
    finally:
        timer.cancel()
    elapsed = time.monotonic() - started
    assert elapsed < after + 1.5, f"{call}: KeyboardInterrupt {elapsed - after:.1f} s after Ctrl-C"
    # the next call runs normally (the stop request was withdrawn)
    assert stiction.detect(long_loop.iloc[:2000])["verdict"] in ("stiction", "no-stiction", "inconclusive")

"""What every ROS test module shares: Python's cyclic garbage collector
runs between tests, never during one.

The peers keep every 1 kHz sample they hear (hundreds of thousands of
objects over a module), so each automatic full collection walked them all
while it held the interpreter: 80-250 ms pauses, 26 in one run of
test_thread.py, in which the peers' callbacks stood still, `HostWatch`
took the pause for the host's and a core went to it while the nodes ran a
thread. Samples are freed by their reference counts; what is left for the
collector (cycles) waits for the next test's start, where
`gc.collect()` runs, and `gc.freeze()` then keeps what survives out of
later collections."""
import gc

import pytest

gc.disable()


@pytest.fixture(autouse=True)
def _collect_between_tests():
    gc.collect()
    gc.freeze()
    yield

"""The Rerun viewer's own screenshot of an .rrd at a moment of its timeline.

    python3 scripts/rerun/screenshot.py IN.rrd OUT.png FRACTION [--size 1600x1000]

Starts the viewer (`rerun`, from rerun-sdk) as a window on the display it
is given (scripts/rerun/screenshots.sh runs it under Xvfb with Mesa's
software Vulkan), opens the file, puts the time cursor at FRACTION of the
`time` timeline (paused) and has the viewer save its window
(rerun.experimental.ViewerClient: open, set_time, save_screenshot).
"""
import argparse
import time

from rerun.chunk import ChunkStore, RrdReader
from rerun.experimental import ViewerClient


def end_of_time(rrd):
    r = RrdReader(rrd)
    store = ChunkStore.from_chunks(list(r.stream(store=r.recordings()[0]).to_chunks()))
    t = store.reader(index="time", contents=["/world/tool"]).to_arrow_table()
    return max(t.column("time").cast("int64").to_pylist()) / 1e9


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("rrd")
    ap.add_argument("png")
    ap.add_argument("fraction", type=float)
    ap.add_argument("--port", type=int, default=9877)
    ap.add_argument("--settle", type=float, default=6.0, help="seconds to let the viewer draw")
    a = ap.parse_args()
    t = a.fraction * end_of_time(a.rrd)
    v = ViewerClient.spawn(headless=False, port=a.port, hide_welcome_screen=True, detach_process=False)
    try:
        v.open(a.rrd)
        time.sleep(a.settle)
        v.set_time("time", duration=t, play_state="paused")
        time.sleep(a.settle)
        v.save_screenshot(a.png)
        print(f"{a.png}: {a.rrd} at t = {t:.3f} s")
    finally:
        v.quit()


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""Headless LinuxCNC "display" for the bench sim.

Started by the linuxcnc launcher as `bench_display.py -ini INIFILE` (see
[DISPLAY]DISPLAY in mill.ini.in / lathe.ini.in).  It:
  1. starts `halsampler -t` writing the raw sampler FIFO to $BENCH_RAW,
  2. resets estop, machine on, homes all joints (instant: no switches),
  3. switches to AUTO, opens $BENCH_PROGRAM, enables sampler.0, runs it,
  4. waits until the program has finished (interpreter idle, exec done,
     motion queue empty, in position, RCS_DONE) plus $BENCH_TAIL_MS ms,
  5. disables the sampler, waits until halsampler's output stops growing
     (FIFO drained), stops halsampler (SIGINT),
  6. exits; the launcher then shuts LinuxCNC down (its normal Cleanup).
Exit status 0 on success, 1 on error (propagated by the launcher).
Messages go to stderr with a "bench:" prefix.
"""
import os
import signal
import subprocess
import sys
import time

import linuxcnc

PROGRAM = os.environ["BENCH_PROGRAM"]
RAW = os.environ["BENCH_RAW"]
TIMEOUT = float(os.environ.get("BENCH_TIMEOUT", "600"))
TAIL_MS = int(os.environ.get("BENCH_TAIL_MS", "50"))


LOG = os.environ.get("BENCH_LOG")


def log(*a):
    # the launcher swallows our stderr when it has no tty (it goes to a temp
    # file that is deleted on success), hence also $BENCH_LOG
    print("bench:", *a, file=sys.stderr, flush=True)
    if LOG:
        with open(LOG, "a") as f:
            print("bench:", *a, file=f)


s = linuxcnc.stat()
c = linuxcnc.command()
e = linuxcnc.error_channel()
errors = []


def drain_errors():
    while True:
        m = e.poll()
        if not m:
            return
        kind, text = m
        if kind in (linuxcnc.NML_ERROR, linuxcnc.OPERATOR_ERROR):
            errors.append(text)
            log("ERROR:", text)
        else:
            log("message:", text)


def wait_for(pred, what, timeout=10.0):
    t0 = time.time()
    while True:
        s.poll()
        drain_errors()
        if pred():
            return
        if errors:
            raise RuntimeError(f"error while waiting for {what}: {errors[-1]}")
        if time.time() - t0 > timeout:
            raise RuntimeError(f"timeout waiting for {what}")
        time.sleep(0.005)


def main():
    sampler_proc = None
    try:
        # task may need a moment after the launcher starts us
        t0 = time.time()
        while True:
            try:
                s.poll()
                break
            except linuxcnc.error:
                if time.time() - t0 > 20:
                    raise
                time.sleep(0.1)

        sampler_proc = subprocess.Popen(["halsampler", "-t"],
                                        stdout=open(RAW, "w"))

        c.state(linuxcnc.STATE_ESTOP_RESET)
        wait_for(lambda: s.task_state == linuxcnc.STATE_ESTOP_RESET, "estop reset")
        c.state(linuxcnc.STATE_ON)
        wait_for(lambda: s.task_state == linuxcnc.STATE_ON, "machine on")
        c.mode(linuxcnc.MODE_MANUAL)
        wait_for(lambda: s.task_mode == linuxcnc.MODE_MANUAL, "manual mode")
        c.teleop_enable(0)
        c.home(-1)
        wait_for(lambda: all(s.homed[i] for i in range(s.joints)), "homing", 20)
        c.mode(linuxcnc.MODE_AUTO)
        wait_for(lambda: s.task_mode == linuxcnc.MODE_AUTO, "auto mode")
        c.program_open(PROGRAM)
        wait_for(lambda: os.path.samefile(s.file, PROGRAM) if s.file else False,
                 "program open")
        log("homed at", [round(p, 4) for p in s.joint_position[:s.joints]],
            "running", PROGRAM)

        # set the signal that drives sampler.0.enable
        subprocess.run(["halcmd", "sets", "sampler-enable", "1"], check=True)
        t_start = time.time()
        c.auto(linuxcnc.AUTO_RUN, 0)
        # wait until task picked up the run command ...
        wait_for(lambda: s.interp_state != linuxcnc.INTERP_IDLE
                 or s.exec_state != linuxcnc.EXEC_DONE or s.queue > 0
                 or time.time() - t_start > 1.0, "program start", 5)
        # ... and until it is over
        wait_for(lambda: s.interp_state == linuxcnc.INTERP_IDLE
                 and s.exec_state == linuxcnc.EXEC_DONE
                 and s.queue == 0 and s.inpos and s.state == linuxcnc.RCS_DONE,
                 "program end", TIMEOUT)
        # tail: keep sampling a little (the converter trims stationary rows)
        time.sleep(TAIL_MS / 1000.0)
        subprocess.run(["halcmd", "sets", "sampler-enable", "0"], check=True)
        wall = time.time() - t_start
        # let halsampler drain the FIFO: wait until the raw file stops growing
        last, stable = -1, 0
        while stable < 10:
            size = os.path.getsize(RAW)
            stable = stable + 1 if size == last else 0
            last = size
            time.sleep(0.02)
        drain_errors()
        log(f"done: wall {wall:.2f} s from run command to sampler off, "
            f"final joints {[round(p, 4) for p in s.joint_position[:s.joints]]}")
        c.state(linuxcnc.STATE_OFF)
    except Exception as ex:  # noqa: BLE001
        log("FAILED:", ex)
        errors.append(str(ex))
    finally:
        if sampler_proc is not None:
            sampler_proc.send_signal(signal.SIGINT)
            try:
                sampler_proc.wait(5)
            except subprocess.TimeoutExpired:
                sampler_proc.kill()
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())

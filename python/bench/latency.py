"""Ctrl-C latency of Surface.mesh (docs/python.md): a timer thread sends
KeyboardInterrupt (as a terminal's SIGINT does) during a level-10 mesh;
prints the time from the signal to the exception and the live threads.

    python python/bench/latency.py
"""
from pathlib import Path
import _thread, threading, time, isoc
s = isoc.load(Path(__file__).resolve().parents[2] / "corpus" / "decocube.iso")
for delay in (0.2, 0.5, 1.0, 1.5, 2.0):
    sent = []
    def fire():
        sent.append(time.perf_counter()); _thread.interrupt_main()
    threading.Timer(delay, fire).start()
    try:
        s.mesh(level=10, kmax=0.05, smooth=0)
        print("finished before the interrupt"); time.sleep(5)
    except KeyboardInterrupt:
        print(f"interrupt at {delay:.1f} s: KeyboardInterrupt after {(time.perf_counter()-sent[0])*1e3:.1f} ms; threads alive {threading.active_count()}")

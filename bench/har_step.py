"""Time of one DeepConvLSTM training step (64 windows of 50 x 6, 27 classes, one thread) and where
it goes, in the BLAS this process loaded: the figure behind docs/har.md's OpenBLAS note.

    PYTHONPATH=build/release/python python3 bench/har_step.py [--steps 20]
    LD_LIBRARY_PATH=/usr/lib/x86_64-linux-gnu/atlas PYTHONPATH=... python3 bench/har_step.py   # ATLAS

Prints the BLAS, the median CPU time of a step over --steps steps after 3 warm-up steps, and the
operators taking most of the time (torch.autograd.profiler, 5 steps).
"""
import argparse
import statistics
import time

import torch

from imukit.har import train
from imukit.har.models import build_model


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=20)
    args = ap.parse_args()
    train.set_threads(1)
    torch.manual_seed(0)
    model = build_model("deepconvlstm", 6, 27)
    opt = torch.optim.Adam(model.parameters(), 1e-3)
    x, y = torch.randn(64, 50, 6), torch.randint(0, 27, (64,))

    def step():
        opt.zero_grad()
        torch.nn.functional.cross_entropy(model(x), y).backward()
        opt.step()

    for _ in range(3):
        step()
    times = []
    for _ in range(args.steps):
        t = time.process_time()
        step()
        times.append(time.process_time() - t)
    print(f"BLAS: {train.blas_library()}")
    print(f"step: {1e3 * statistics.median(times):.1f} ms CPU (median of {args.steps})")
    with torch.autograd.profiler.profile() as prof:
        for _ in range(5):
            step()
    print(prof.key_averages().table(sort_by="self_cpu_time_total", row_limit=6))


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""A training loop shaped like a PyTorch one, with physically plausible augmentation (PPDA) in it.

Nothing is trained (NumPy only, PyTorch may not be installed): the point is where imukit goes.
Per mini-batch the loop, which owns the policy's logits (what the paper learns), draws ONE
sub-policy with a Gumbel-softmax-style sample over the logits, asks imukit to simulate that
batch's windows under it (C++ threads, GIL released, written straight into a reused float32
buffer), and times each batch. In PyTorch the buffer would go to torch.from_numpy(buffer)
without a copy, and the relaxed one-hot `soft` would carry the gradient to the logits.

    PYTHONPATH=build/release/python python3 python/examples/training_loop.py
    ... --scene my_scene.json --policy paper --batch-size 256 --epochs 2
"""
import argparse
import json
import time

import numpy as np

import imukit

# A stand-in scene when none is given: the default humanoid moving procedurally for 2 minutes,
# a watch on the left wrist and a phone in the right trouser pocket, sampled at 50 Hz.
DEMO_SCENE = {
    "schema": "imukit.scene/1",
    "body": {"default_humanoid": {"height_m": 1.75}},
    "motion": {"procedural": {"rate_hz": 100, "duration_s": 120, "seed": 1}},
    "simulation": {"rate_hz": 50},
    "sensors": [{"name": "watch", "preset": "left_wrist_watch"},
                {"name": "phone", "preset": "right_front_pocket_phone"}],
}


def softmax(z):
    e = np.exp(z - np.max(z))
    return e / e.sum()


def gumbel_softmax(logits, temperature, rng):
    """Relaxed one-hot sample (Jang et al. 2017): softmax((logits + g) / temperature) with
    g ~ Gumbel(0, 1). Its argmax is an exact sample of softmax(logits) (the Gumbel-max trick);
    the soft vector is what a differentiable policy search back-propagates through."""
    u = rng.uniform(np.finfo(float).tiny, 1.0, size=logits.shape)
    g = -np.log(-np.log(u))
    soft = softmax((logits + g) / temperature)
    return int(np.argmax(soft)), soft


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", help="scene JSON (imukit.scene/1); default: a built-in procedural scene")
    ap.add_argument("--policy", default="imukit", help="built-in policy name or policy JSON")
    ap.add_argument("--epochs", type=int, default=2)
    ap.add_argument("--batches", type=int, default=4, help="mini-batches per epoch")
    ap.add_argument("--batch-size", type=int, default=256)
    ap.add_argument("--window", type=int, default=100, help="samples per window")
    ap.add_argument("--stride", type=int, default=25)
    ap.add_argument("--temperature", type=float, default=1.0)
    ap.add_argument("--threads", type=int, default=0, help="C++ threads (0: all cores)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    scene = imukit.read_scene(args.scene) if args.scene else imukit.parse_scene(json.dumps(DEMO_SCENE))
    policy = imukit.read_policy(args.policy)
    augmenter = imukit.Augmenter(scene, window=args.window)
    names = policy.describe()
    starts = augmenter.window_starts(args.stride)
    print(f"scene: sensors {augmenter.sensor_names} at {augmenter.rate_hz:g} Hz, {len(starts)} base windows; "
          f"policy '{policy.name}': {len(policy)} sub-policies")

    rng = np.random.default_rng(args.seed)  # the loop's own randomness (shuffling, Gumbel noise)
    logits = np.zeros(len(policy))          # the loop holds the policy; uniform to start with
    buffer = np.empty((args.batch_size, args.window, augmenter.channels), np.float32)
    times = []
    for epoch in range(args.epochs):
        order = rng.permutation(starts)
        for b in range(args.batches):
            batch_starts = np.resize(np.roll(order, -b * args.batch_size), args.batch_size)
            k, soft = gumbel_softmax(logits, args.temperature, rng)
            probabilities = softmax(logits)
            t0 = time.perf_counter()
            # One sub-policy for the whole batch; seed per (epoch, batch) so a run is reproducible.
            x = augmenter.apply(k, batch_starts, args.seed * 1_000_003 + epoch * 10_007 + b, policy=policy,
                                out=buffer, threads=args.threads)
            t_augment = time.perf_counter() - t0
            times.append(t_augment)
            # The model step would go here: loss = criterion(model(torch.from_numpy(x)), y);
            # loss.backward() also reaches the logits through `soft`. Stand-in: per-channel RMS.
            rms = np.sqrt(np.mean(np.square(x), axis=(0, 1)))
            print(f"epoch {epoch} batch {b}: sub-policy {k:3d} p={probabilities[k]:.4f} soft={soft[k]:.3f} "
                  f"{x.shape} {1e3 * t_augment:7.1f} ms  |acc| rms {np.linalg.norm(rms[:3]):.2f} m/s^2  "
                  f"[{names[k]}]")
    per_window = 1e6 * np.median(times) / args.batch_size
    print(f"median {1e3 * np.median(times):.1f} ms per batch of {args.batch_size} ({per_window:.0f} us per window)")


if __name__ == "__main__":
    main()

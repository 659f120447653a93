#!/usr/bin/env python3
"""Torch reference for the nn micro-benchmark (benches/ppo_update.rs in the repository root): the paper's PPO update shape on CPU.

Per minibatch of 6144 rows: actor forward, a second actor forward on another input (symmetry term), critic forward,
a scalar loss touching all three outputs (mean of squares), backward, plain SGD step. 24 576 samples x 5 epochs =
20 minibatches. samples/s = 24 576 / seconds for the whole 5-epoch update (as in shared/notes/candle-cpu-profile.md);
GFLOP/s counts the nominal FLOPs of the whole update (16.76 MFLOP per sample for the paper's networks). Also times
the batched inference forward (4096 rows).

    python examples/torch_reference.py --threads 1
    python examples/torch_reference.py --threads 2 [--hidden 256,128,64]
"""
import argparse
import time

import torch
from torch import nn

OBS, ACT = 42, 10
SAMPLES, MINIBATCH, EPOCHS = 24576, 6144, 5


def flop_per_sample(hidden):
    """Nominal FLOPs per sample for the whole update: per epoch 3 forward passes (2 actor, 1 critic) at 2 FLOP per
    multiply-add and their backward at twice that; 16.76 M for the paper's networks (the notes' "~16.8 M")."""
    def macs(dims):
        return sum(a * b for a, b in zip(dims, dims[1:]))
    return EPOCHS * 6.0 * (2 * macs([OBS] + hidden + [ACT]) + macs([OBS] + hidden + [1]))


def mlp(dims):
    layers = []
    for i in range(len(dims) - 1):
        layers.append(nn.Linear(dims[i], dims[i + 1]))
        if i + 2 < len(dims):
            layers.append(nn.ELU())
    return nn.Sequential(*layers)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--lr", type=float, default=1e-3)
    p.add_argument("--hidden", default="512,256,128")
    a = p.parse_args()
    hidden = [int(h) for h in a.hidden.split(",")]
    flops = flop_per_sample(hidden)
    torch.set_num_threads(a.threads)
    torch.manual_seed(0)
    actor = mlp([OBS] + hidden + [ACT])
    critic = mlp([OBS] + hidden + [1])
    params = list(actor.parameters()) + list(critic.parameters())
    obs = torch.randn(SAMPLES, OBS)
    mirrored = torch.randn(SAMPLES, OBS)
    opt = torch.optim.SGD(params, lr=a.lr)

    def update():
        for _ in range(EPOCHS):
            for i in range(SAMPLES // MINIBATCH):
                x = obs[i * MINIBATCH:(i + 1) * MINIBATCH]
                xm = mirrored[i * MINIBATCH:(i + 1) * MINIBATCH]
                mu = actor(x)
                mu_m = actor(xm)
                v = critic(x)
                loss = mu.square().mean() + mu_m.square().mean() + v.square().mean()
                opt.zero_grad(set_to_none=True)
                loss.backward()
                opt.step()
        return loss.item()

    update()  # warm-up
    best = None
    for _ in range(a.repeats):
        t = time.perf_counter()
        update()
        dt = time.perf_counter() - t
        best = dt if best is None else min(best, dt)
        print(f"torch threads={a.threads} update {dt:.3f} s  {SAMPLES / dt:8.0f} samples/s  "
              f"{SAMPLES * flops / dt / 1e9:6.1f} GFLOP/s")
    print(f"torch threads={a.threads} best: {SAMPLES / best:.0f} samples/s, "
          f"{SAMPLES * flops / best / 1e9:.1f} GFLOP/s")

    x = torch.randn(4096, OBS)
    with torch.inference_mode():
        for _ in range(10):
            actor(x)
        n = 200
        t = time.perf_counter()
        for _ in range(n):
            actor(x)
        dt = (time.perf_counter() - t) / n
    print(f"torch threads={a.threads} inference 4096 rows: {dt * 1e3:.3f} ms/call")


if __name__ == "__main__":
    main()

"""Benchmark of the Bingham core: speed and accuracy of every normaliser method, and the sampler.

Run: ``.venv/bin/python benchmarks/bingham.py`` (``make bench``). Writes
``benchmarks/results/bingham.json`` and prints a Markdown table (copied into docs/bingham.md).

All methods run in one process on the same random eigenvalues: B = 100 000 float64 eigenvalue
sets with log-uniform concentrations in [1e-3, 1e6] (one eigenvalue 0), timed for the value and
its gradient (forward + backward), median of repeats. Accuracy is the maximum relative error of C
against mpmath (`symgrasp.bingham.reference`) on a log-spaced grid over [−1e6, 0]^{d−1}.
``--quick`` runs everything once on a small batch and a coarse grid.
"""

from __future__ import annotations

import argparse
import itertools
import json
import statistics
import time
from pathlib import Path

import lab  # noqa: F401  (puts the checkout's root on sys.path, for experiments.scripts)
import numpy as np
import torch
from tqdm import tqdm

from experiments.scripts import command_line, machine, parse_args, run_main
from symgrasp.bingham import Bingham, eigh3, log_normalizer, nll, triu_to_sym
from symgrasp.bingham.normalizer import _S2_NODES, _S2_WINDOW, _gauss_legendre, _s2_quadrature
from symgrasp.bingham.reference import log_normalizer_mpmath

RESULTS = Path(__file__).parent / "results" / "bingham.json"
METHODS = {3: ["quadrature", "paper"], 4: ["bessel", "paper"]}


def random_eigenvalues(batch: int, d: int, seed: int) -> torch.Tensor:
    generator = torch.Generator().manual_seed(seed)
    log_kappa = torch.rand(batch, d - 1, generator=generator, dtype=torch.float64) * 9 - 3
    return torch.cat([-(10**log_kappa), torch.zeros(batch, 1, dtype=torch.float64)], -1)


def bessel_candidate(lam: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """The S² alternative first suggested (the I₀ᵉ integral), measured to justify the choice:
    C = 4π ∫₀¹ e^{λ₁u²} I₀ᵉ(−λ₂(1−u²)/2) du with the same node count and Gaussian window as
    ``"quadrature"``; moments from the I₁ᵉ derivative. Same inputs and outputs as the kernel."""
    a = lam[..., 0].abs().unsqueeze(-1)
    b = lam[..., 1].abs().unsqueeze(-1)
    nodes, weights = _gauss_legendre(_S2_NODES, lam.device)
    window = torch.clamp(_S2_WINDOW / a.sqrt(), max=1.0)
    u2 = (window * nodes).square()
    x = b * (1 - u2) / 2
    i0, i1 = torch.special.i0e(x), torch.special.i1e(x)
    base = window * weights * torch.exp(-a * u2)
    c = (base * i0).sum(-1)
    moment1 = (base * u2 * i0).sum(-1) / c
    moment2 = (base * (1 - u2) / 2 * (i0 - i1)).sum(-1) / c
    moments = torch.stack([moment1, moment2, 1 - moment1 - moment2], dim=-1)
    return torch.log(4 * torch.pi * c), moments


def time_kernel(kernel, lam: torch.Tensor, repeats: int) -> float:
    """Median seconds of a kernel (value and moments, i.e. the gradient) on sorted, shifted λ."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        kernel(lam)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def time_value_and_gradient(lam: torch.Tensor, method: str, repeats: int) -> float:
    """Median seconds for log C and its gradient over the whole batch."""
    times = []
    for _ in range(repeats):
        x = lam.clone().requires_grad_(True)
        start = time.perf_counter()
        log_normalizer(x, method).sum().backward()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def accuracy_grid(d: int, points: int) -> list[list[float]]:
    values = [0.0, *(-np.logspace(-3, 6, points)).tolist()]
    rows = [sorted(t) for t in itertools.product(values, repeat=d - 1)]
    unique = sorted({tuple(r) for r in rows})
    return [[*r, 0.0] for r in unique]


def max_relative_error(grid: list[list[float]], reference: torch.Tensor, method: str) -> float:
    log_c = log_normalizer(torch.tensor(grid, dtype=torch.float64), method)
    return (torch.expm1(log_c - reference)).abs().max().item()


def sampler_throughput(batch: int, d: int, per_distribution: int, seed: int, repeats: int) -> dict:
    """Samples per second for ``batch`` distinct random distributions (eigh included)."""
    generator = torch.Generator().manual_seed(seed)
    lam = random_eigenvalues(batch, d, seed)
    q = torch.linalg.qr(torch.randn(batch, d, d, generator=generator, dtype=torch.float64))[0]
    A = q @ torch.diag_embed(lam) @ q.transpose(-1, -2)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        Bingham(A).sample((per_distribution,), generator=generator)
        times.append(time.perf_counter() - start)
    rate = Bingham(A).acceptance_rate(200, generator=generator)
    seconds = statistics.median(times)
    return {
        "distributions": batch,
        "samples_per_distribution": per_distribution,
        "seconds": seconds,
        "samples_per_second": batch * per_distribution / seconds,
        "acceptance_rate_mean": rate.mean().item(),
        "acceptance_rate_min": rate.min().item(),
    }


def loss_and_eigen_timings(batch: int, seed: int, repeats: int) -> dict:
    """µs per element: the S² eigensolvers, and the 2D-Bingham NLL with its backward pass
    (float32 network output → triu → nll, as in training)."""
    generator = torch.Generator().manual_seed(seed)
    a = torch.randn(batch, 6, generator=generator) * 10
    v = torch.nn.functional.normalize(torch.randn(batch, 3, generator=generator), dim=-1)
    A = triu_to_sym(a).double()

    def nll_step() -> None:
        x = a.clone().requires_grad_(True)
        nll(triu_to_sym(x), v).sum().backward()

    def median_us(fn) -> float:
        fn()
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            fn()
            times.append(time.perf_counter() - start)
        return statistics.median(times) / batch * 1e6

    return {
        "batch": batch,
        "eigh3_us": median_us(lambda: eigh3(A)),
        "torch_linalg_eigh_us": median_us(lambda: torch.linalg.eigh(A)),
        "nll_s2_float32_forward_backward_us": median_us(nll_step),
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--batch", type=int, default=100_000, help="eigenvalue sets timed (default 100000)"
    )
    parser.add_argument(
        "--repeats", type=int, default=5, help="timing repeats, median reported (default 5)"
    )
    parser.add_argument(
        "--grid", type=int, default=25, help="S² accuracy grid points per axis (default 25)"
    )
    parser.add_argument(
        "--grid-s3", type=int, default=8, help="S³ accuracy grid points per axis (default 8)"
    )
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument(
        "--out", type=Path, default=RESULTS, help=f"JSON output (default {RESULTS})"
    )
    args = parse_args(
        parser, outputs=("out",), quick={"batch": 1000, "repeats": 1, "grid": 2, "grid_s3": 2}
    )

    result: dict = {
        "command": command_line(""),
        "machine": machine(),
    }
    result["setup"] = {"batch": args.batch, "dtype": "float64", "device": "cpu", "seed": args.seed}
    result["normalizer"] = {}
    for d, methods in METHODS.items():
        lam = random_eigenvalues(args.batch, d, args.seed)
        grid = accuracy_grid(d, args.grid if d == 3 else args.grid_s3)
        reference = torch.tensor(
            [log_normalizer_mpmath(g) for g in tqdm(grid, desc=f"mpmath reference S{d - 1}")],
            dtype=torch.float64,
        )
        for method in methods:
            log_normalizer(lam[:1000], method)  # warm-up
            repeats = args.repeats if method != "paper" else max(1, args.repeats // 2)
            seconds = time_value_and_gradient(lam, method, repeats)
            result["normalizer"][f"S{d - 1}/{method}"] = {
                "us_per_constant_with_gradient": seconds / args.batch * 1e6,
                "max_relative_error": max_relative_error(grid, reference, method),
                "grid_points": len(grid),
            }
        fast, paper = (result["normalizer"][f"S{d - 1}/{m}"] for m in methods)
        fast["speedup_over_paper"] = (
            paper["us_per_constant_with_gradient"] / fast["us_per_constant_with_gradient"]
        )
        if d == 3:  # the erf quadrature against the I₀ᵉ integral first suggested, kernel to kernel
            shifted = lam.sort(-1).values
            shifted = shifted - shifted[..., -1:]
            rows = torch.tensor(grid, dtype=torch.float64).sort(-1).values
            result["s2_kernel_choice"] = {
                name: {
                    "us_per_constant_with_moments": time_kernel(kernel, shifted, args.repeats)
                    / args.batch
                    * 1e6,
                    "max_relative_error": torch.expm1(kernel(rows)[0] - reference)
                    .abs()
                    .max()
                    .item(),
                }
                for name, kernel in [
                    ("erf (chosen)", _s2_quadrature),
                    ("bessel I0e", bessel_candidate),
                ]
            }
    result["loss"] = loss_and_eigen_timings(min(args.batch, 65_536), args.seed, args.repeats)
    result["sampler"] = {
        "S2": sampler_throughput(args.batch, 3, 10, args.seed, args.repeats),
        "S3": sampler_throughput(args.batch, 4, 10, args.seed, args.repeats),
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_suffix(".tmp")
    tmp.write_text(json.dumps(result, indent=2) + "\n")
    tmp.replace(args.out)

    print(
        f"\nmachine: {result['machine']['cpu']}, {result['machine']['torch_threads']} threads, torch {result['machine']['torch']}"
    )
    print(
        f"\n| normaliser | µs per constant + gradient (B = {args.batch}) | max rel. error of C vs mpmath | speed-up vs paper |"
    )
    print("|---|---|---|---|")
    for name, r in result["normalizer"].items():
        speedup = f"{r['speedup_over_paper']:.0f}×" if "speedup_over_paper" in r else "—"
        print(
            f"| {name} | {r['us_per_constant_with_gradient']:.2f} | {r['max_relative_error']:.1e} ({r['grid_points']} points) | {speedup} |"
        )
    print("\n| S² kernel (value + moments) | µs per constant | max rel. error |")
    print("|---|---|---|")
    for name, r in result["s2_kernel_choice"].items():
        print(
            f"| {name} | {r['us_per_constant_with_moments']:.2f} | {r['max_relative_error']:.1e} |"
        )
    r = result["loss"]
    print(f"\n| S² at B = {r['batch']} | µs per element |")
    print("|---|---|")
    print(f"| `eigh3` (closed form) | {r['eigh3_us']:.3f} |")
    print(f"| `torch.linalg.eigh` | {r['torch_linalg_eigh_us']:.3f} |")
    print(
        f"| `nll` forward + backward (float32 input) | {r['nll_s2_float32_forward_backward_us']:.3f} |"
    )
    print("\n| sampler | distributions | samples/s | acceptance rate (mean, min) |")
    print("|---|---|---|---|")
    for name, r in result["sampler"].items():
        print(
            f"| {name} | {r['distributions']} × {r['samples_per_distribution']} | {r['samples_per_second']:.3g} | {r['acceptance_rate_mean']:.3f}, {r['acceptance_rate_min']:.3f} |"
        )
    print(f"\nwrote {args.out}")


if __name__ == "__main__":
    run_main(main)

#!/usr/bin/env python3
"""Cross-check a garmatnet model file against PyTorch, and time PyTorch on the CPU.

Loads the same .safetensors file garmatnet writes into an equivalent PyTorch module,
feeds it the inputs `cargo run --release --example net_reference` wrote, checks that both
nets' de-normalised outputs match garmatnet's within 1e-4 (relative to the output's
largest magnitude), and times PyTorch at batch 1 and batch B next to garmatnet's own
timing from the same run.

    pip install -r benches/requirements.txt
    cargo run --release --example net_reference -- --model MODEL --out out/net_reference
    python3 benches/pytorch_crosscheck.py --model MODEL --reference out/net_reference

Exits non-zero when the outputs disagree.
"""

import argparse
import json
import math
import struct
import sys
import time
from pathlib import Path

import numpy as np
import torch
from safetensors.torch import load_file

TOLERANCE = 1e-4

# MaterialBounds::STANDARD (crates/garmatnet-core/src/material/bounds.rs): structural V/H,
# flexion V/H, shear, density.
BOUNDS = [(10.0, 20_000.0)] * 2 + [(0.01, 2_000.0)] * 2 + [(1.0, 20_000.0), (0.02, 1.0)]


def uniform_scaling_direction() -> torch.Tensor:
    """Material::uniform_scaling_direction: the unit shift of normalised ω under a common scaling."""
    v = torch.tensor([1.0 / math.log(hi / lo) for lo, hi in BOUNDS], dtype=torch.float64)
    return v / v.norm()


def rotation_minus_identity(pose: torch.Tensor) -> torch.Tensor:
    """PoseEncoding::RotationMatrix: each joint's R(theta_j) - I by Rodrigues, [B, 72] -> [B, 216]."""
    x = pose.reshape(pose.shape[0], 24, 3)
    angle = x.norm(dim=2, keepdim=True)[..., None]  # [B, 24, 1, 1]
    safe = torch.where(angle > 0, angle, torch.ones_like(angle))
    sin_over = torch.where(angle > 0, torch.sin(safe) / safe, torch.ones_like(angle))
    one_minus_cos_over = torch.where(angle > 0, (1 - torch.cos(safe)) / safe**2, 0.5 * torch.ones_like(angle))
    zero = torch.zeros_like(x[..., 0])
    cross = torch.stack([
        torch.stack([zero, -x[..., 2], x[..., 1]], dim=-1),
        torch.stack([x[..., 2], zero, -x[..., 0]], dim=-1),
        torch.stack([-x[..., 1], x[..., 0], zero], dim=-1),
    ], dim=-2)  # [B, 24, 3, 3]
    outer = x[..., :, None] * x[..., None, :] - angle**2 * torch.eye(3, dtype=x.dtype)
    return (sin_over * cross + one_minus_cos_over * outer).reshape(pose.shape[0], 216)


def read_header(path: Path) -> dict:
    """The garmatnet JSON document in the safetensors __metadata__."""
    with open(path, "rb") as f:
        (length,) = struct.unpack("<Q", f.read(8))
        header = json.loads(f.read(length))
    return json.loads(header["__metadata__"]["garmatnet"])


class GarMatNet(torch.nn.Module):
    """The GarMatNet MLP with garmatnet's tensor layout (weights stored [d_in, d_out])."""

    def __init__(self, tensors: dict, prefix: str, config: dict):
        super().__init__()
        self.alpha = float(config["alpha"])
        self.scale_free = bool(config.get("scale_free_material", False))
        self.pose_encoding = config.get("pose_encoding", "axis_angle")
        if self.pose_encoding not in ("axis_angle", "rotation_matrix"):
            raise ValueError(f"unknown pose_encoding {self.pose_encoding!r}")
        self.layers = {
            name: (tensors[f"{prefix}.{name}.weight"].double(), tensors[f"{prefix}.{name}.bias"].double())
            for name in ("pose_in", "material_in", "merge", "output")
        }
        self.basis = tensors.get(f"{prefix}.basis")
        self.basis_mean = tensors.get(f"{prefix}.basis_mean")
        if self.basis is not None:
            self.basis, self.basis_mean = self.basis.double(), self.basis_mean.double()

    def linear(self, name, x):
        w, b = self.layers[name]
        return x @ w + b

    def forward(self, pose, material):
        if self.scale_free:
            u = uniform_scaling_direction().to(material.dtype)
            material = material - (material @ u)[:, None] * u[None, :]
        if self.pose_encoding == "rotation_matrix":
            pose = rotation_minus_identity(pose)
        p = torch.tanh(self.linear("pose_in", pose * (1.0 - self.alpha)))
        m = torch.tanh(self.linear("material_in", material * self.alpha))
        h = torch.tanh(self.linear("merge", torch.cat([p, m], dim=1)))  # dropout: eval mode
        y = self.linear("output", h)
        if self.basis is not None:
            y = y @ self.basis + self.basis_mean
        return y


def median_ms(fn, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append((time.perf_counter() - start) * 1e3)
    return sorted(times)[len(times) // 2]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", type=Path, required=True)
    parser.add_argument("--reference", type=Path, default=Path("out/net_reference"))
    parser.add_argument("--dtype", choices=["float32", "float64"], default="float32",
                        help="PyTorch precision for the timing (the check runs in float64)")
    args = parser.parse_args()

    header = read_header(args.model)
    tensors = load_file(str(args.model))
    nets = {name: GarMatNet(tensors, name, header[name]) for name in ("fitting", "local")}
    norms = {name: (tensors[f"{name}_norm.mean"].double(), tensors[f"{name}_norm.std"].double())
             for name in ("fitting", "local")}
    pose = torch.from_numpy(np.load(args.reference / "pose.npy"))
    material = torch.from_numpy(np.load(args.reference / "material.npy"))

    ok = True
    with torch.no_grad():
        for name, net in nets.items():
            mean, std = norms[name]
            ours = net(pose, material) * std + mean
            theirs = torch.from_numpy(np.load(args.reference / f"{name}.npy"))
            scale = max(theirs.abs().max().item(), 1e-12)
            err = (ours - theirs).abs().max().item() / scale
            verdict = "ok" if err <= TOLERANCE else "MISMATCH"
            ok &= err <= TOLERANCE
            print(f"{name:8s} net: max |PyTorch - garmatnet| / max|output| = {err:.2e} ({verdict}, tolerance {TOLERANCE:g})")

        dtype = torch.float32 if args.dtype == "float32" else torch.float64
        for net in nets.values():
            net.layers = {k: (w.to(dtype), b.to(dtype)) for k, (w, b) in net.layers.items()}
            if net.basis is not None:
                net.basis, net.basis_mean = net.basis.to(dtype), net.basis_mean.to(dtype)
        p, m = pose.to(dtype), material.to(dtype)
        both = lambda rows: [net(p[:rows], m[:rows]) for net in nets.values()]
        both(1)
        batch = pose.shape[0]
        t1 = median_ms(lambda: both(1), 50)
        tb = median_ms(lambda: both(batch), 10) / batch

    rust = json.loads((args.reference / "timing.json").read_text())
    print()
    print(f"| both nets, CPU | batch 1 (ms) | batch {batch} (ms/frame) |")
    print("|---|---:|---:|")
    print(f"| garmatnet ({rust['backend']}, {rust['threads']} threads) | {rust['batch1_ms']:.3f} | {rust['batched_ms_per_frame']:.3f} |")
    print(f"| PyTorch {torch.__version__} ({args.dtype}, {torch.get_num_threads()} threads) | {t1:.3f} | {tb:.3f} |")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

"""The per-axis networks g_phi_i of paper 000 (Definition 3, two tanh hidden layers and a linear
output, eq. 13) forward and backward in one compiled (numba) kernel each, float32.

Why: on a minibatch of 1e4 samples the networks' small matrix products (K = 16 or 30) run far
below the CPU's arithmetic rate in BLAS, and torch or numpy pass over memory once per
elementwise operation (bias, tanh, its derivative). Here the samples are cut into tiles of
``TILE`` that stay in the L1/L2 cache; each layer of a tile is computed row by row with the
samples as the inner, vectorized loop, tanh included (``tanh32``). ``benchmarks/pgnn_speed.py``
gives the ratio to torch's autograd on the same networks.

Layout. Inputs x (B, n) are padded with zeros to a multiple of ``TILE`` and stored as tiles
(n_tiles, n, TILE), samples last; the activations of the two hidden layers are kept for the
backward pass as (n_axes, n_tiles, width, TILE). A padded sample gets an output gradient of zero,
so it adds nothing to any weight's gradient.

Weights are those of the ``nn.Sequential`` of ``network.mlp`` (Linear, Tanh, Linear, Tanh,
Linear without bias), stacked over axes: W1 (A, h1, n), b1 (A, h1), W2 (A, h2, h1), b2 (A, h2),
w3 (A, h2). Gradients are accumulated per tile in float32, as a BLAS product accumulates them.
"""

from __future__ import annotations

import numpy as np
import torch

from ...physics.compiled import FASTMATH, Kernels

TILE = 256
"""Samples per tile: 30 rows of 256 float32 fit the 32 KiB L1 cache."""

njit = Kernels(__file__)
# error_model="numpy": no division-by-zero check in the loops, which would stop their vectorization
_jit = njit(fastmath=FASTMATH, error_model="numpy")

# tanh(x) = x p(x^2) / q(x^2) on |x| <= CLAMP, +-1 (in float32) beyond: a rational minimax fit
# (the one of the Eigen library's float tanh), within 3e-7 of the exact value (tests/test_pgnn_fused.py)
CLAMP = 7.90531110763549805
P = (-2.76076847742355e-16, 2.00018790482477e-13, -8.60467152213735e-11, 5.12229709037114e-08,
     1.48572235717979e-05, 6.37261928875436e-04, 4.89352455891786e-03)
Q = (1.19825839466702e-06, 1.18534705686654e-04, 2.26843463243900e-03, 4.89352518554385e-03)
_P0, _P1, _P2, _P3, _P4, _P5, _P6 = (np.float32(c) for c in P)
_Q0, _Q1, _Q2, _Q3 = (np.float32(c) for c in Q)
_CLAMP = np.float32(CLAMP)


@njit(fastmath=FASTMATH, error_model="numpy", inline="always")
def tanh32(x):
    """tanh of a float32 without a library call, so that a loop of it vectorizes."""
    x = min(max(x, -_CLAMP), _CLAMP)
    x2 = x * x
    p = ((((((_P0 * x2 + _P1) * x2 + _P2) * x2 + _P3) * x2 + _P4) * x2 + _P5) * x2 + _P6) * x
    q = ((_Q0 * x2 + _Q1) * x2 + _Q2) * x2 + _Q3
    return p / q


@_jit
def tanh_array(x):
    """``tanh32`` of every element of a float32 array (for tests and benchmarks)."""
    out = np.empty_like(x)
    flat, res = x.reshape(-1), out.reshape(-1)
    for i in range(flat.size):
        res[i] = tanh32(flat[i])
    return out


@njit(fastmath=FASTMATH, error_model="numpy", inline="always")
def _layer(out, W, b, inputs):
    """out[j] = tanh(b[j] + sum_k W[j, k] inputs[k]) for each row j, over the tile's samples:
    out (h, T), W (h, m), b (h,), inputs (m, T)."""
    T = out.shape[1]
    for j in range(W.shape[0]):
        z = out[j]
        bias = b[j]
        for t in range(T):
            z[t] = bias
        for k in range(W.shape[1]):
            w, xk = W[j, k], inputs[k]
            for t in range(T):
                z[t] += w * xk[t]
        for t in range(T):
            z[t] = tanh32(z[t])


@_jit
def forward_kernel(x, W1, b1, W2, b2, w3, a1, a2, y):
    """y[a] = w3[a] . tanh(W2[a] tanh(W1[a] x + b1[a]) + b2[a]) per tile. x (n_tiles, n, T);
    a1 (A, n_tiles, h1, T), a2 (A, n_tiles, h2, T): the hidden activations (written); y (A, n_tiles, T)."""
    n_axes, n_tiles, T = W1.shape[0], x.shape[0], x.shape[2]
    for a in range(n_axes):
        for c in range(n_tiles):
            _layer(a1[a, c], W1[a], b1[a], x[c])
            _layer(a2[a, c], W2[a], b2[a], a1[a, c])
            out = y[a, c]
            for t in range(T):
                out[t] = 0.0
            for j in range(W2.shape[1]):
                w, h = w3[a, j], a2[a, c, j]
                for t in range(T):
                    out[t] += w * h[t]


@_jit
def backward_kernel(x, W2, w3, a1, a2, dy, gW1, gb1, gW2, gb2, gw3, d1, d2):
    """Gradients of sum(dy * y) with respect to the weights (written into gW1 ... gw3, shaped like
    the weights), from the activations of ``forward_kernel``. dy (A, n_tiles, T); d1 (A, h1, T) and
    d2 (A, h2, T) scratch: the gradients of the hidden layers' pre-activations within a tile."""
    n_axes, h2, h1 = W2.shape
    n_tiles, n, T = x.shape
    one = np.float32(1.0)
    for a in range(n_axes):
        gW1[a] = 0.0
        gb1[a] = 0.0
        gW2[a] = 0.0
        gb2[a] = 0.0
        gw3[a] = 0.0
        for c in range(n_tiles):
            g = dy[a, c]
            for j in range(h2):  # output layer, then the second hidden layer's pre-activation
                h, dj, w = a2[a, c, j], d2[a, j], w3[a, j]
                s3 = np.float32(0.0)
                sb = np.float32(0.0)
                for t in range(T):
                    s3 += g[t] * h[t]
                    d = g[t] * w * (one - h[t] * h[t])
                    dj[t] = d
                    sb += d
                gw3[a, j] += s3
                gb2[a, j] += sb
                for k in range(h1):
                    hk = a1[a, c, k]
                    s = np.float32(0.0)
                    for t in range(T):
                        s += dj[t] * hk[t]
                    gW2[a, j, k] += s
            for k in range(h1):  # the first hidden layer
                dk = d1[a, k]
                for t in range(T):
                    dk[t] = 0.0
                for j in range(h2):
                    w, dj = W2[a, j, k], d2[a, j]
                    for t in range(T):
                        dk[t] += w * dj[t]
                hk = a1[a, c, k]
                sb = np.float32(0.0)
                for t in range(T):
                    d = dk[t] * (one - hk[t] * hk[t])
                    dk[t] = d
                    sb += d
                gb1[a, k] += sb
                for i in range(n):
                    xi = x[c, i]
                    s = np.float32(0.0)
                    for t in range(T):
                        s += dk[t] * xi[t]
                    gW1[a, k, i] += s


@_jit
def to_tiles(v, out, columns_first):
    """Write v (B, m) float32 into tiles with zero padding: out[c, i, t] = v[c TILE + t, i] with
    ``out`` (n_tiles, m, TILE), or out[i, c, t] with ``out`` (m, n_tiles, TILE) where ``columns_first``."""
    B, m = v.shape
    n_tiles = out.shape[1] if columns_first else out.shape[0]
    T = out.shape[2]
    for c in range(n_tiles):
        for i in range(m):
            row = out[i, c] if columns_first else out[c, i]
            for t in range(T):
                s = c * T + t
                row[t] = v[s, i] if s < B else 0.0


class _Scratch:
    """Arrays the kernels write, kept for the next call of the same shape: a fresh array of a few
    MiB costs more in page faults than the kernel that fills it. A set taken by a forward pass that
    will be differentiated comes back after its backward pass (``FusedMLP``), else at once."""

    def __init__(self):
        self._free: dict[tuple, list] = {}

    def take(self, n_in: int, n_axes: int, h1: int, h2: int, n_tiles: int) -> dict[str, np.ndarray]:
        key = (n_in, n_axes, h1, h2, n_tiles)
        free = self._free.get(key)
        if free:
            return free.pop()
        f32 = np.float32
        return {"key": key, "x": np.empty((n_tiles, n_in, TILE), f32), "dy": np.empty((n_axes, n_tiles, TILE), f32),
                "a1": np.empty((n_axes, n_tiles, h1, TILE), f32), "a2": np.empty((n_axes, n_tiles, h2, TILE), f32),
                "d1": np.empty((n_axes, h1, TILE), f32), "d2": np.empty((n_axes, h2, TILE), f32)}

    def give(self, arrays: dict[str, np.ndarray]) -> None:
        free = self._free.setdefault(arrays["key"], [])
        if len(free) < 2:
            free.append(arrays)


_scratch = _Scratch()


class FusedMLP(torch.autograd.Function):
    """Outputs (B, A) of the A per-axis networks on standardized inputs x (B, n), with the stacked
    weights (module docstring); the gradient flows to the weights only (x is data). ``keep``: whether
    a backward pass will follow (the activations are then kept for it)."""

    @staticmethod
    def forward(ctx, x, W1, b1, W2, b2, w3, keep):
        B = x.shape[0]
        n_axes, h1, n_in = W1.shape
        s = _scratch.take(n_in, n_axes, h1, W2.shape[1], -(-B // TILE))
        to_tiles(x.detach().contiguous().numpy(), s["x"], False)
        y = np.empty((n_axes, s["x"].shape[0], TILE), dtype=np.float32)
        weights = [w.detach().contiguous().numpy() for w in (W1, b1, W2, b2, w3)]
        forward_kernel(s["x"], *weights, s["a1"], s["a2"], y)
        if keep:
            ctx.saved = (s, weights, B)
        else:
            _scratch.give(s)
        return torch.from_numpy(np.ascontiguousarray(y.reshape(n_axes, -1)[:, :B].T))

    @staticmethod
    def backward(ctx, grad):
        s, (W1, b1, W2, b2, w3), B = ctx.saved
        del ctx.saved
        if ctx.needs_input_grad[0]:
            raise NotImplementedError("FusedMLP: no gradient with respect to the inputs (they are data)")
        to_tiles(grad.detach().to(torch.float32).contiguous().numpy(), s["dy"], True)
        grads = [np.empty_like(w) for w in (W1, b1, W2, b2, w3)]
        backward_kernel(s["x"], W2, w3, s["a1"], s["a2"], s["dy"], *grads, s["d1"], s["d2"])
        _scratch.give(s)
        return (None, *(torch.from_numpy(g) for g in grads), None)


def fusable(net: torch.nn.Sequential) -> bool:
    """Whether ``net`` is the paper's network the kernels compute: Linear, Tanh, Linear, Tanh,
    Linear without bias, float32 on the CPU."""
    kinds = [type(layer).__name__ for layer in net]
    return (kinds == ["Linear", "Tanh", "Linear", "Tanh", "Linear"] and net[4].bias is None
            and all(p.dtype == torch.float32 and p.device.type == "cpu" for p in net.parameters()))


def fused_networks(x: torch.Tensor, nets) -> torch.Tensor:
    """(B, A): each of the ``nets`` (all ``fusable``, of one shape) on x (B, n) float32."""
    W1, b1, W2, b2, w3 = (torch.stack([net[i].weight if name == "weight" else net[i].bias for net in nets])
                          for i, name in ((0, "weight"), (0, "bias"), (2, "weight"), (2, "bias"), (4, "weight")))
    keep = torch.is_grad_enabled() and W1.requires_grad
    return FusedMLP.apply(x.to(torch.float32), W1, b1, W2, b2, w3.reshape(len(nets), -1), keep)

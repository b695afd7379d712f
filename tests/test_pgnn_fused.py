"""The PGNN's compiled networks (``lcgym.methods.pgnn.fused``) against torch's autograd on the same weights."""

import numpy as np
import pytest
import torch

from lcgym.methods.pgnn import fused
from lcgym.methods.pgnn.network import PGNNModule, mlp
from lcgym.systems.ix import IX


def test_tanh32_is_tanh_to_float32_accuracy():
    x = np.linspace(-12, 12, 480_001, dtype=np.float32)
    y = fused.tanh_array(x).astype(float)
    exact = np.tanh(x.astype(float))
    assert np.abs(y - exact).max() < 5e-7
    assert np.array_equal(y, -fused.tanh_array(-x).astype(float))  # odd
    assert np.all(np.abs(y) <= 1.0)
    assert np.abs(y[np.abs(x) > 9] - np.sign(x[np.abs(x) > 9])).max() < 1e-6  # saturates


def reference(nets, x, dy):
    """Outputs and weight gradients of sum(dy * y) by torch's autograd on copies of ``nets``."""
    copies = [mlp(x.shape[1], (net[0].out_features, net[2].out_features), "tanh") for net in nets]
    for c, net in zip(copies, nets, strict=True):
        c.load_state_dict(net.state_dict())
    y = torch.cat([c(x) for c in copies], dim=1)
    (y * dy).sum().backward()
    return y.detach(), [p.grad for c in copies for p in c.parameters()]


@pytest.mark.parametrize(("n_axes", "n_in", "hidden", "batch"),
                         [(2, 16, (30, 30), 10_000), (6, 24, (20, 12), fused.TILE + 3), (1, 4, (30, 30), 1)])
def test_fused_networks_equal_autograd(n_axes, n_in, hidden, batch):
    torch.manual_seed(1)
    nets = [mlp(n_in, hidden, "tanh") for _ in range(n_axes)]
    x = torch.randn(batch, n_in) * 2
    dy = torch.randn(batch, n_axes)
    y_ref, g_ref = reference(nets, x, dy)
    y = fused.fused_networks(x, nets)
    (y * dy).sum().backward()
    assert y.shape == (batch, n_axes)
    assert torch.allclose(y, y_ref, rtol=0, atol=1e-6)
    for p, g in zip([p for net in nets for p in net.parameters()], g_ref, strict=True):
        assert torch.allclose(p.grad, g, rtol=1e-5, atol=1e-5 * float(g.abs().max()))


def test_kept_activations_survive_other_forward_passes():
    """A forward pass without gradients between a forward pass and its backward pass must not
    overwrite the activations kept for it (``fused._Scratch``)."""
    torch.manual_seed(2)
    nets = [mlp(8, (30, 30), "tanh") for _ in range(2)]
    x, other, dy = torch.randn(600, 8), torch.randn(600, 8), torch.randn(600, 2)
    _, g_ref = reference(nets, x, dy)
    y = fused.fused_networks(x, nets)
    with torch.no_grad():
        fused.fused_networks(other, nets)
    (y * dy).sum().backward()
    for p, g in zip([p for net in nets for p in net.parameters()], g_ref, strict=True):
        assert torch.allclose(p.grad, g, rtol=1e-5, atol=1e-5 * float(g.abs().max()))


def test_module_uses_the_kernels_for_the_papers_networks_only():
    torch.manual_seed(3)
    x = torch.randn(50, 16)
    paper = PGNNModule(IX, IX.nominal_params().to_vector(), 16)
    assert all(fused.fusable(net) for net in paper.nets)
    xs = (x - paper.input_mean) / paper.input_std
    assert torch.allclose(paper.network(x), torch.cat([net(xs) for net in paper.nets], dim=1), atol=1e-6)
    for hidden, activation in (((30, 30), "relu"), ((30,), "tanh"), ((10, 10, 10), "tanh")):
        other = PGNNModule(IX, IX.nominal_params().to_vector(), 16, hidden, activation)
        assert not any(fused.fusable(net) for net in other.nets)
        assert other.network(x).shape == (50, 2)
    assert not fused.fusable(paper.nets[0].double())

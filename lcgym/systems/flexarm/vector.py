"""Compiled step of N FlexArm envs at once (numba, parallel over arms): the kernel of
``env.FlexArmVectorEnv``.

The physics is not rewritten here: each arm advances by ``plant.loop_sample``, the per-sample
closed loop that ``FlexArmPlant.run`` and the single ``FlexArmEnv`` use, and the encoders are read
by ``plant._measure``. What this module adds is the env's bookkeeping per arm in compiled code:
the action's clipping, the observation and the reward (``observe`` and ``reward_of``, which the
single ``FlexArmEnv`` uses too) and the episode status, so that each sub-env's numbers are those
of a single env fed the same actions (``tests/test_env_flexarm.py`` checks it bit for bit).

References arrive stacked and padded to the longest, (R, T_max, 6), with their lengths (R,);
``scales`` packs the env's constants (``SCALES`` below gives the order).
"""

from __future__ import annotations

import numba
import numpy as np

from ...physics import linalg
from ...physics.compiled import Kernels
from . import dynamics as arm
from . import plant as F

njit = Kernels(__file__, F.__file__, arm.__file__, linalg.__file__)

SCALES = ("pos", "vel", "acc", "ff", "err", "err_clip", "reward", "obs_bound", "preview", "action_bound")
ENV_OK, ENV_DIVERGED = 0, 1
N_OBS = 36

_loop_sample = F.loop_sample
_measure = F._measure


@njit
def observe(st, ref_pos, ref_vel, ref_acc, base_ff, T, k, N, res, scales, out):
    """The observation (36,) of ``env.FlexArmEnv`` at sample k of a reference of length T into
    ``out`` (float32); returns the encoder-side error e = q_lr(k) - q_m / N (6,) [rad]."""
    kk = min(k, T - 1)
    ahead = min(kk + int(scales[8]), T - 1)
    e = np.empty(6)
    for j in range(6):
        e[j] = ref_pos[kk, j] - _measure(st, j, res) / N[j]
    bound = scales[7]
    for j in range(6):
        vals = (ref_pos[kk, j] / scales[0], ref_vel[kk, j] / scales[1], ref_acc[kk, j] / scales[2],
                base_ff[kk, j] / scales[3], ref_vel[ahead, j] / scales[1],
                min(max(e[j] / scales[4], -scales[5]), scales[5]))
        for g in range(6):
            out[6 * g + j] = min(max(vals[g], -bound), bound)
    return e


@njit
def reward_of(e, scale):
    """The env's reward -1/2 sum_i (e_i / scale)^2 for the encoder-side error e (6,) [rad]."""
    total = 0.0
    for j in range(6):
        total += (e[j] / scale) ** 2
    return -0.5 * total


@njit
def step_one(b, st, ref_pos, ref_vel, ref_acc, base_ff, offset, lengths, ref_idx, k, action, scales,
             dh, pi, drive, C, cfg, accel_offset, obs, reward, status, clipped, u, load_error):
    """One sample of sub-env b (see ``env.FlexArmEnv.step``); ``u`` gets the motor torques [N m] and
    ``load_error`` the true load-side error q_lr - q_l [rad] of the sample (before it)."""
    r, kk = ref_idx[b], k[b]
    T = lengths[r]
    bound = scales[9]
    a = action[b].copy()
    over = False
    for j in range(6):
        if abs(a[j]) > bound:
            over = True
    if over:
        clipped[b] += 1
        for j in range(6):
            a[j] = min(max(a[j], -bound), bound)
    ff = base_ff[r, kk] + a
    sig = np.zeros(F.N_SIG)
    bad = _loop_sample(st[b], ref_pos[r, kk], ref_pos[r, min(kk + 1, T - 1)], ff, offset[r, kk], dh, pi, drive, C,
                       cfg, accel_offset, sig, True)
    for j in range(6):
        u[b, j] = sig[F.S_U + j]
        load_error[b, j] = ref_pos[r, kk, j] - sig[F.S_QL + j]
    k[b] = kk + 1
    e = observe(st[b], ref_pos[r], ref_vel[r], ref_acc[r], base_ff[r], T, kk + 1, drive[0], cfg[3], scales, obs[b])
    reward[b] = reward_of(e, scales[6])
    status[b] = ENV_DIVERGED if bad else ENV_OK


# The same loop twice: threads pay off from a few dozen arms on (the parallel one's start-up costs
# more than a handful of arms' samples). Two functions, not one compiled twice: numba's disk cache
# keys a kernel by its function's name and line, so a parallel and a serial compilation of one
# function share an entry and whichever was compiled first is loaded for both.
@njit
def step_serial(active, st, ref_pos, ref_vel, ref_acc, base_ff, offset, lengths, ref_idx, k, action, scales, dh, pi,
                drive, C, cfg, accel_offset, obs, reward, status, clipped, u, load_error):
    for b in range(st.shape[0]):
        if active[b]:
            step_one(b, st, ref_pos, ref_vel, ref_acc, base_ff, offset, lengths, ref_idx, k, action, scales, dh, pi,
                     drive, C, cfg, accel_offset, obs, reward, status, clipped, u, load_error)


@njit(parallel=True)
def step_parallel(active, st, ref_pos, ref_vel, ref_acc, base_ff, offset, lengths, ref_idx, k, action, scales, dh,
                  pi, drive, C, cfg, accel_offset, obs, reward, status, clipped, u, load_error):
    for b in numba.prange(st.shape[0]):
        if active[b]:
            step_one(b, st, ref_pos, ref_vel, ref_acc, base_ff, offset, lengths, ref_idx, k, action, scales, dh, pi,
                     drive, C, cfg, accel_offset, obs, reward, status, clipped, u, load_error)

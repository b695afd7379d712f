"""Compiled closed-loop simulation of the IX (numba): the inner loop of ``systems/ix/plant.py``.

Why compiled: a 500 Hz plant with several integrator substeps per sample needs tens of
millions of right-hand-side evaluations for the paper's 1e6-sample data set; per-sample numpy
calls cost microseconds each, far over the 10 s budget. The equations are not rewritten here:
the kernel calls the same functions as the model (``systems.ix.dynamics.rigid_terms`` and the basis
functions of ``physics.effects``), compiled by numba.

Effect parameters arrive packed in a (2, STATIC + width) array, one row per axis: the IX's own
friction law (Coulomb level, guidance friction, Stribeck rise, LuGre stiction) and the effects
that change its equation's structure (cable inertia, torque ripple, two-mass drive) in the slots
below (a zero amplitude switches an effect off), then from ``STATIC`` on the effects that add a
torque of q and qd, in the records of ``physics.plant_effects`` (every plant's one formula);
``plant.py`` does the packing.

State of one plant, per axis i in (0 propeller, 1 roll): load angle and velocity q_i, qd_i,
motor angle and velocity (equal to the load's without drivetrain flexibility) and the LuGre
bristle state z_i: ``s = [q0, q1, qd0, qd1, qm0, qm1, qmd0, qmd1, z0, z1]``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ...physics import effects as fx
from ...physics import plant_effects
from ...physics.compiled import FASTMATH, Kernels
from . import dynamics as ix
from . import effects as ix_effects

njit = Kernels(__file__, ix.__file__, fx.__file__, ix_effects.__file__, plant_effects.__file__)

# effect parameter slots (per axis row)
(
    FC, EPS, PD_COS, PD_COS_ROLL, PD_SIN, ST_DF, ST_VS, LG_S0, LG_S1,
    CI_DJ, CI_Q0, CI_W, RP_AS, RP_AC, RP_PER, FX_K, FX_C, FX_JM,
) = range(18)
STATIC = 18  # the records of the effects of q and qd (physics.plant_effects) start here
N_STATE = 10
# controller slots (per axis row)
KP, KD, ALPHA = range(3)

# status codes
OK, DIVERGED = 0, 1

_rigid = ix.rigid_terms
_sign = fx.smooth_sign
_normal = ix_effects.normal_force_basis
_stribeck = fx.stribeck_shape
_inertia = fx.cable_inertia_basis
_periodic = fx.periodic_basis
_effects = plant_effects.axis_torque


@njit(fastmath=FASTMATH)
def friction_level(v, e, nb):
    """Friction level L(q) [V] (Coulomb + normal-force part) and Stribeck increment at speed v.

    Beyond 8 Stribeck velocities the increment (below 2e-28 of dF) is skipped as zero.
    """
    level = e[FC] + e[PD_COS] * nb[0] + e[PD_COS_ROLL] * nb[1] + e[PD_SIN] * nb[2]
    strib = 0.0
    if e[ST_DF] != 0.0 and abs(v) < 8.0 * e[ST_VS]:
        strib = e[ST_DF] * _stribeck(v, e[ST_VS])
    return level, strib


@njit(fastmath=FASTMATH)
def joint_trig(s, trig):
    """trig = (sin q2, cos q2, sin q3, cos q3) of state s: shared by the relaxation and the RHS."""
    trig[0], trig[1] = math.sin(s[0]), math.cos(s[0])
    trig[2], trig[3] = math.sin(s[1]), math.cos(s[1])


@njit(fastmath=FASTMATH)
def lugre_relax(s, trig, E, h):
    """Advance the LuGre bristle states z over h exactly for frozen q, v (half of a Strang split).

    zdot = v - a z with a = sigma0 |v| L / (L + dF_stribeck) gives z(h) = v/a + (z - v/a) e^{-a h}.
    The relaxation rate a (several thousand per second while sliding) is far faster than the
    mechanics; solving it exactly keeps the integration stable at any speed.
    """
    nb = _normal(trig[0], trig[1], trig[3])
    for i in range(2):
        e = E[i]
        if e[LG_S0] <= 0.0:
            continue
        v = s[2 + i]
        level, strib = friction_level(v, e, nb)
        if level <= 0.0:
            continue
        a = e[LG_S0] * abs(v) * level / (level + strib)
        if a > 0.0:
            z_ss = v / a
            s[8 + i] = z_ss + (s[8 + i] - z_ss) * math.exp(-a * h)


@njit(fastmath=FASTMATH)
def axis_terms(s, i, u, e, nb):
    """Effects and drive of axis i: (added inertia, generalized force on the load, motor acc).

    The force excludes H and D of the rigid body; e is the axis's effect-parameter row and nb the
    normal-force basis of the current configuration.
    """
    q, v = s[i], s[2 + i]
    tau = 0.0
    added_inertia = 0.0
    if e[CI_DJ] != 0.0:  # cable inertia: dJ shape(q) joins M, 1/2 dJ shape'(q) v^2 joins the force
        shape, centrifugal = _inertia(q, v, 0.0, e[CI_Q0], e[CI_W])
        added_inertia = e[CI_DJ] * shape
        tau += e[CI_DJ] * centrifugal
    tau = _effects(e[STATIC:], q, v, 0.0, tau)  # the effects of q and qd (physics.plant_effects)
    # friction: level L(q), Stribeck increment, LuGre bristles or the static smooth-sign curve
    level, strib = friction_level(v, e, nb)
    if e[LG_S0] > 0.0 and level > 0.0:  # LuGre force; z itself is advanced by lugre_relax
        z = s[8 + i]
        zdot = v - e[LG_S0] * abs(v) * z * level / (level + strib)
        tau += level * (e[LG_S0] * z + e[LG_S1] * zdot)
    elif level != 0.0 or strib != 0.0:
        tau += (level + strib) * _sign(v, e[EPS])
    # drive: ripple scales the motor torque; a flexible drive puts a spring between motor and load
    torque = u
    if e[RP_PER] != 0.0:
        r = _periodic(s[4 + i], e[RP_PER])
        torque = u * (1.0 + e[RP_AS] * r[0] + e[RP_AC] * r[1])
    motor_acc = 0.0
    if e[FX_K] > 0.0:
        coupling = e[FX_K] * (s[4 + i] - q) + e[FX_C] * (s[6 + i] - v)
        motor_acc = (torque - coupling) / e[FX_JM]
        torque = coupling
    return added_inertia, torque - tau, motor_acc


@njit(fastmath=FASTMATH)
def derivatives(s, trig, u, p, E, ds):
    """ds = d/dt s for input u (2,) [V] held constant; p true rigid parameters of the load;
    trig = joint_trig(s)."""
    s2, c2, s3, c3 = trig[0], trig[1], trig[2], trig[3]
    m22, m23, m33, h2, h3 = _rigid(p, s2, c2, s3, c3, s[2], s[3])
    nb = _normal(s2, c2, c3)
    dm0, f0, acc0 = axis_terms(s, 0, u[0], E[0], nb)
    dm1, f1, acc1 = axis_terms(s, 1, u[1], E[1], nb)
    ds[8], ds[9] = 0.0, 0.0  # bristle states: see lugre_relax
    m0, m1 = m22 + dm0, m33 + dm1
    r0 = f0 - h2 - p[ix.D2] * s[2]
    r1 = f1 - h3 - p[ix.D3] * s[3]
    det = m0 * m1 - m23 * m23
    ds[0], ds[1] = s[2], s[3]
    ds[2] = (m1 * r0 - m23 * r1) / det
    ds[3] = (m0 * r1 - m23 * r0) / det
    # motor states: own dynamics with a flexible drive, else they follow the load
    ds[4], ds[6] = (s[6], acc0) if E[0, FX_K] > 0.0 else (ds[0], ds[2])
    ds[5], ds[7] = (s[7], acc1) if E[1, FX_K] > 0.0 else (ds[1], ds[3])


@njit(fastmath=FASTMATH)
def rk4_interval(s, u, p, E, dt, substeps, work):
    """Advance state s in place over dt with input u held: ``substeps`` Strang-split steps, each
    an exact half-step of the bristle relaxation, a classical RK4 step of the mechanics (bristle
    states frozen) and another exact half-step. Second order overall. work: scratch (6, N_STATE).
    """
    h = dt / substeps
    k1, k2, k3, k4, tmp, trig = work[0], work[1], work[2], work[3], work[4], work[5]
    joint_trig(s, trig)  # the relaxation changes z only: the angles stay, and so do their sines
    for _ in range(substeps):
        lugre_relax(s, trig, E, 0.5 * h)
        derivatives(s, trig, u, p, E, k1)
        for j in range(N_STATE):
            tmp[j] = s[j] + 0.5 * h * k1[j]
        joint_trig(tmp, trig)
        derivatives(tmp, trig, u, p, E, k2)
        for j in range(N_STATE):
            tmp[j] = s[j] + 0.5 * h * k2[j]
        joint_trig(tmp, trig)
        derivatives(tmp, trig, u, p, E, k3)
        for j in range(N_STATE):
            tmp[j] = s[j] + h * k3[j]
        joint_trig(tmp, trig)
        derivatives(tmp, trig, u, p, E, k4)
        for j in range(N_STATE):
            s[j] += h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
        joint_trig(s, trig)
        lugre_relax(s, trig, E, 0.5 * h)


N_WORK = 6  # rows of rk4_interval's scratch

# closed-loop state: plant state, controller state (e[k-1], fb[k-1] per axis), input being applied
N_LOOP = N_STATE + 6
CS0, UA0 = N_STATE, N_STATE + 4
# configuration slots
CFG_UMAX, CFG_TS, CFG_ERR, CFG_VEL, CFG_SUB, CFG_RES0, CFG_RES1 = range(7)
N_CFG = 7
# per-sample signals written by loop_sample
SIG_Y, SIG_U, SIG_FB, SIG_LOAD = 0, 2, 4, 6
N_SIG = 8


@njit(fastmath=FASTMATH)
def sensor(s, E, cfg, out):
    """Quantized encoder reading [rad]: motor side when the drive is flexible (in axis units)."""
    for i in range(2):
        x = s[4 + i] if E[i, FX_K] > 0.0 else s[i]
        res = cfg[CFG_RES0 + i]
        out[i] = math.floor(x / res + 0.5) * res if res > 0.0 else x


@njit(fastmath=FASTMATH)
def control(ref, meas, ff, C, cs, cfg, out_u, out_fb):
    """Diagonal PD + first-order low-pass (per axis), plus feedforward, saturated at +-umax.

    cs = [e_prev0, e_prev1, ufb0, ufb1] is updated in place.
    ufb[k] = alpha ufb[k-1] + (1 - alpha) (Kp e[k] + Kd (e[k] - e[k-1]) / Ts)
    """
    ts, umax = cfg[CFG_TS], cfg[CFG_UMAX]
    for i in range(2):
        e = ref[i] - meas[i]
        raw = C[i, KP] * e + C[i, KD] * (e - cs[i]) / ts
        cs[2 + i] = C[i, ALPHA] * cs[2 + i] + (1.0 - C[i, ALPHA]) * raw
        cs[i] = e
        out_fb[i] = cs[2 + i]
        out_u[i] = min(max(cs[2 + i] + ff[i], -umax), umax)


@njit(fastmath=FASTMATH)
def loop_start(st, ref0, E, cfg):
    """Plant at rest at ref0 (motor = load, no bristle deflection), controller without history."""
    st[:] = 0.0
    st[0], st[1] = ref0[0], ref0[1]
    st[4], st[5] = ref0[0], ref0[1]
    y = np.empty(2)
    sensor(st, E, cfg, y)
    st[CS0], st[CS0 + 1] = ref0[0] - y[0], ref0[1] - y[1]


@njit(fastmath=FASTMATH)
def loop_sample(st, ref_k, ff_k, p, E, C, cfg, work, sig):
    """One sample k of the closed loop, in place on st (N_LOOP,).

    The encoders read y[k]; the controller computes u[k], which is applied over [t_{k+1},
    t_{k+2}) (one-sample computation delay, zero-order hold); the plant integrates over
    [t_k, t_{k+1}) with u[k-1]. sig receives y[k], u[k], fb[k] and the load angles at t_k.
    """
    s = st[:N_STATE]
    sensor(s, E, cfg, sig[SIG_Y : SIG_Y + 2])
    control(ref_k, sig[SIG_Y : SIG_Y + 2], ff_k, C, st[CS0 : CS0 + 4], cfg, sig[SIG_U : SIG_U + 2], sig[SIG_FB : SIG_FB + 2])
    sig[SIG_LOAD], sig[SIG_LOAD + 1] = s[0], s[1]
    rk4_interval(s, st[UA0 : UA0 + 2], p, E, cfg[CFG_TS], int(cfg[CFG_SUB]), work)
    st[UA0], st[UA0 + 1] = sig[SIG_U], sig[SIG_U + 1]


@njit(fastmath=FASTMATH)
def out_of_range(s, ref, cfg):
    """True if a state is not finite, the tracking error exceeds CFG_ERR or a speed CFG_VEL."""
    for j in range(N_STATE):
        if not math.isfinite(s[j]):
            return True
    for i in range(2):
        if abs(ref[i] - s[i]) > cfg[CFG_ERR] or abs(s[2 + i]) > cfg[CFG_VEL]:
            return True
    return False


@njit(fastmath=FASTMATH)
def settle(st, ref0, ff0, n_samples, p, E, C, cfg, work):
    """Start at ref0 and hold ref0, ff0 for n_samples (gravity sag, friction states settle)."""
    loop_start(st, ref0, E, cfg)
    sig = np.empty(N_SIG)
    for _ in range(n_samples):
        loop_sample(st, ref0, ff0, p, E, C, cfg, work, sig)


@njit(parallel=True, fastmath=FASTMATH)
def simulate_batch(ref, ff, lengths, p, E, C, cfg, preroll, sig_out, status, fail_k, final_state):
    """Closed-loop runs of B references at once (parallel over references).

    ref, ff: (B, T, 2) reference [rad] and feedforward [V]; lengths (B,) valid samples of each.
    ``preroll`` samples holding ref[0], ff[0] settle the plant before recording. sig_out
    (B, T, N_SIG) receives the per-sample signals of loop_sample.
    """
    B = ref.shape[0]
    for b in numba.prange(B):
        st = np.empty(N_LOOP)
        work = np.empty((N_WORK, N_STATE))
        settle(st, ref[b, 0], ff[b, 0], preroll, p, E, C, cfg, work)
        status[b] = OK
        fail_k[b] = -1
        for k in range(lengths[b]):
            loop_sample(st, ref[b, k], ff[b, k], p, E, C, cfg, work, sig_out[b, k])
            if out_of_range(st, ref[b, min(k + 1, lengths[b] - 1)], cfg):
                status[b] = DIVERGED
                fail_k[b] = k
                break
        final_state[b, :] = st[:N_STATE]


# ---------------------------------------------------------------------------------------------
# Gymnasium environments: one control sample per env step (env.py)
# ---------------------------------------------------------------------------------------------
ENV_OK, ENV_DIVERGED, ENV_BAD_ACTION = 0, 1, 2
# env signals: loop signals, then feedforward, tracking error at t_k, next encoder reading
SIG_FF, SIG_ERR, SIG_NEXT = N_SIG, N_SIG + 2, N_SIG + 4
N_ENV_SIG = N_SIG + 6
SC_ERR, SC_CLIP, SC_REWARD, SC_BOUND = range(4)  # env scales: obs error, obs clip, reward error, action bound


@njit(fastmath=FASTMATH)
def env_step_one(b, st, work, ref_pos, feats, base_ff, lengths, ref_idx, k, action, scales, p, E, C, cfg,
                 obs, reward, status, clipped, sig):
    """Step env b by one sample with feedforward base_ff + clip(action); write its observation,
    reward and status. See env.py for the meaning of each quantity."""
    r, kb = ref_idx[b], k[b]
    if not (math.isfinite(action[b, 0]) and math.isfinite(action[b, 1])):
        status[b] = ENV_BAD_ACTION
        return
    bound = scales[SC_BOUND]
    for i in range(2):
        a = action[b, i]
        if a > bound or a < -bound:
            a = min(max(a, -bound), bound)
            clipped[b] += 1
        sig[b, SIG_FF + i] = base_ff[r, kb, i] + a
    loop_sample(st[b], ref_pos[r, kb], sig[b, SIG_FF : SIG_FF + 2], p, E, C, cfg, work[b], sig[b])
    for i in range(2):
        sig[b, SIG_ERR + i] = ref_pos[r, kb, i] - sig[b, SIG_Y + i]
    kn = min(kb + 1, lengths[r] - 1)
    sensor(st[b], E, cfg, sig[b, SIG_NEXT : SIG_NEXT + 2])
    nf = feats.shape[2]
    obs[b, :nf] = feats[r, kn]
    rew = 0.0
    for i in range(2):
        e = ref_pos[r, kn, i] - sig[b, SIG_NEXT + i]
        obs[b, nf + i] = min(max(e / scales[SC_ERR], -scales[SC_CLIP]), scales[SC_CLIP])
        rew -= 0.5 * (e / scales[SC_REWARD]) ** 2
    reward[b] = rew
    k[b] = kb + 1
    status[b] = ENV_DIVERGED if out_of_range(st[b], ref_pos[r, kn], cfg) else ENV_OK


@njit(fastmath=FASTMATH)
def env_step_serial(active, st, work, ref_pos, feats, base_ff, lengths, ref_idx, k, action, scales, p, E, C, cfg,
                    obs, reward, status, clipped, sig):
    for b in range(st.shape[0]):
        if active[b]:
            env_step_one(b, st, work, ref_pos, feats, base_ff, lengths, ref_idx, k, action, scales, p, E, C, cfg,
                         obs, reward, status, clipped, sig)


@njit(parallel=True, fastmath=FASTMATH)
def env_step_parallel(active, st, work, ref_pos, feats, base_ff, lengths, ref_idx, k, action, scales, p, E, C, cfg,
                      obs, reward, status, clipped, sig):
    for b in numba.prange(st.shape[0]):
        if active[b]:
            env_step_one(b, st, work, ref_pos, feats, base_ff, lengths, ref_idx, k, action, scales, p, E, C, cfg,
                         obs, reward, status, clipped, sig)

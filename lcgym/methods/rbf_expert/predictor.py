"""The NN predictor of paper 002 (Fig. 3): motion influence, preprocessing, expert activation,
four RBF networks per joint, postprocessing.

Trained once on trajectories whose model-following error was measured (on the arm: e_pl from the
end-effector accelerometer, in the factory), it predicts the error of any new trajectory from its
reference alone:

1. motion influence Q, Qd, Qdd of every joint (``influence``, eqs. 22-24);
2. per joint the preprocessing of section 3.2 (``preprocess``), fitted on all training samples;
3. per viable sample the active network (``expert``, Table 3; with ``cruise_and_rest``, the
   default, also the two experts at constant velocity and at rest);
4. per joint and network type an ``RBFNetwork`` on (v11, v22, v33) (3D) or (v22, v33) (2D), neuron
   ranges of Table 5 (cruise: on (v11, v21); rest: on v11 and the direction of the last motion,
   ``expert.CRUISE_REST_RANGES``), trained on the samples where it is active, with the safety rule
   of ``network`` (prediction fading to zero outside the training data);
5. the prediction, zero where no network is active, low-passed zero-phase at ``lowpass_hz``
   (section 3.5, 50 Hz: above Q_u's 20 Hz).

``outside_share_`` after ``predict``: per joint, the share of the trajectory's viable samples (the
reference moves) that are outside the training data: input confidence below 1, a v33 level no
training sample reached, or a network type with too few training samples.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ...fitted import check_fitted
from ...physics.kinematics import lowpass_zero_phase, relay
from .expert import CRUISE, CRUISE_REST_RANGES, NETWORK_TYPES, REST, TABLE5_RANGES, ExpertConfig, network_types
from .influence import motion_influence
from .network import MomentumRules, RBFNetwork
from .preprocess import PreprocessConfig, Preprocessor


@dataclass(frozen=True)
class RBFExpertConfig:
    """dims: 3 (v11, v22, v33) or 2 (v22, v33); counts: neurons per dimension (the paper's 20 x 10
    x 11; the last two for 2D); sigma: RBF width; method: "lstsq" (direct, default) or "momentum"
    (eqs. 36-38, Table 4); support, ridge: the safety rule's threshold and the ridge weight
    (``network``); lowpass_hz: postprocessing filter [Hz]; min_samples: a network with fewer
    training samples is not trained (predicts zero); cruise_and_rest: the two experts beyond Table 3
    (``expert``; False: the paper's four, ``paper002-nnp``).

    Defaults differing from the paper's choice, chosen on the FlexArm (``studies/rbf_expert_arm.py
    --tune``; the evidence in docs/methods/rbf-expert.md): 2D, not 3D networks (the lines fill the
    position dimension too thinly); 10 levels for eq. (29); a 0.5 s "long period" of constant
    velocity (``expert.ExpertConfig``); ridge 10.
    """

    dims: int = 2
    counts: tuple[int, ...] = (20, 10, 11)
    sigma: float = 0.07
    method: str = "lstsq"
    support: float | None = 1.0
    ridge: float = 10.0
    lowpass_hz: float = 50.0
    min_samples: int = 50
    cruise_and_rest: bool = True
    preprocess: PreprocessConfig = field(default_factory=PreprocessConfig)
    expert: ExpertConfig = field(default_factory=ExpertConfig)
    rules: MomentumRules = field(default_factory=MomentumRules)

    def __post_init__(self):
        if self.dims not in (2, 3):
            raise ValueError(f"dims must be 2 or 3, got {self.dims}")
        if len(self.counts) not in (self.dims, 3) or min(self.counts) < 2:
            raise ValueError(f"counts must give >= 2 neurons for each of the {self.dims} dimensions, got {self.counts}")
        if not self.sigma > 0 or not self.lowpass_hz > 0:
            raise ValueError("sigma and lowpass_hz must be positive")
        if self.method not in ("lstsq", "momentum"):
            raise ValueError(f"method must be 'lstsq' or 'momentum', got {self.method!r}")

    @property
    def grid(self) -> tuple[int, ...]:
        return tuple(self.counts[-self.dims:])


CRUISE_REST_WIDTH = 3.0
"""The cruise and rest experts' RBF width, in units of ``sigma``: a new trajectory cruises at speeds
and rests at places the training ones did not, between the lines their samples lie on (on a made-up
error of the velocity, tests/test_rbf_expert.py, the error left at cruise fell from 0.19 at the
paper's width to 0.03 of 0.26 at 3x; on the four machines 2-4x gave the same tracking)."""


class RBFExpertPredictor:
    """Predicts the error (T, n) of a trajectory from its reference. phi: the (n, n) motion
    influence matrix; joints: indices of the joints that get networks (the others: zero).

    ``fit(references, errors)``: references with ``positions``, ``velocities``, ``accelerations``
    (T, n) and ``fs``; errors (T, n) each, what was measured on them. Learned: ``preprocessors_``
    and ``networks_`` {joint: {type: RBFNetwork}}; ``train_samples_`` {joint: {type: count}}."""

    def __init__(self, phi: np.ndarray, joints: Sequence[int], config: RBFExpertConfig | None = None):
        self.phi = phi
        self.joints = joints
        self.config = config

    @property
    def config_(self) -> RBFExpertConfig:
        return self.config or RBFExpertConfig()

    def inputs(self, reference, joint: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Network inputs X (T, dims), active network type (T,) and where a prediction is made (T,)
        bool (viable; and at rest with ``cruise_and_rest``) of one joint for a reference; at cruise
        and rest the first two columns of X hold those experts' inputs."""
        cfg = self.config_
        Q, Qd, Qdd = (m[:, joint] for m in motion_influence(np.asarray(self.phi, dtype=float), reference.positions,
                                                              reference.velocities, reference.accelerations))
        v = self.preprocessors_[joint].transform(Q, Qd, Qdd)
        types = network_types(v["v22"], v["v33"], v["viable"], reference.fs, cfg.expert, cfg.cruise_and_rest)
        X = np.column_stack([v["v11"], v["v22"], v["v33"]][3 - cfg.dims:])
        if not cfg.cruise_and_rest:
            return X, types, v["viable"]
        last = relay(np.where(v["viable"], v["v21"], 0.0)[:, None])[:, 0]  # the direction of the last motion
        for t, cols in ((CRUISE, (v["v11"], np.clip(v["v21"], -1.0, 1.0))), (REST, (v["v11"], last))):
            sel = types == t
            X[sel, :2] = np.column_stack(cols)[sel]
        return X, types, v["viable"] | (types == REST)

    def fit(self, references: Sequence, errors: Sequence[np.ndarray]) -> RBFExpertPredictor:
        cfg = self.config_
        if len(references) != len(errors) or not references:
            raise ValueError(f"RBFExpertPredictor.fit: {len(references)} references but {len(errors)} error records")
        phi = np.asarray(self.phi, dtype=float)
        n = references[0].positions.shape[1]
        if phi.shape != (n, n) or not set(self.joints) <= set(range(n)):
            raise ValueError(f"RBFExpertPredictor: Phi is {phi.shape} and joints {tuple(self.joints)} for references "
                             f"with {n} axes")
        influence = [motion_influence(phi, r.positions, r.velocities, r.accelerations) for r in references]
        self.preprocessors_, self.networks_, self.train_samples_ = {}, {}, {}
        for j in self.joints:
            cat = [np.concatenate([m[k][:, j] for m in influence]) for k in range(3)]
            e_all = np.concatenate([np.asarray(e, dtype=float)[:, j] for e in errors])
            self.preprocessors_[j] = Preprocessor(cfg.preprocess).fit(*cat, e_all)
            X, types, _ = zip(*(self.inputs(r, j) for r in references), strict=True)
            X, types = np.concatenate(X), np.concatenate(types)
            self.networks_[j], self.train_samples_[j] = {}, {}
            for t in self.types:
                sel = types == t
                self.train_samples_[j][t] = int(sel.sum())
                if sel.sum() < cfg.min_samples:
                    continue
                ranges, grid, sigma, x = self._network_inputs(t, X[sel])
                net = RBFNetwork(ranges, grid, sigma, self.preprocessors_[j].beta0_, cfg.method, cfg.rules,
                                 cfg.support, cfg.ridge)
                self.networks_[j][t] = net.fit(x, e_all[sel])
        return self

    @property
    def types(self) -> tuple[int, ...]:
        """The network types it trains: Table 3's, with the cruise and rest experts where configured."""
        return (*NETWORK_TYPES, CRUISE, REST) if self.config_.cruise_and_rest else NETWORK_TYPES

    def _network_inputs(self, t: int, X: np.ndarray) -> tuple[tuple, tuple[int, ...], float, np.ndarray]:
        """(neuron ranges, neurons per dimension, width, inputs) of network type ``t`` for its rows of
        X: Table 5's for types 1-4; the cruise and rest experts' two inputs with ``counts[0]`` and
        ``counts[1]`` neurons at cruise (position, velocity), ``counts[0]`` and three at rest (the
        last direction is -1, 0 or +1), twice as wide (``CRUISE_REST_WIDTH``)."""
        cfg = self.config_
        if t in NETWORK_TYPES:
            return TABLE5_RANGES[t][3 - cfg.dims:], cfg.grid, cfg.sigma, X
        return (CRUISE_REST_RANGES[t], (cfg.counts[0], cfg.counts[1] if t == CRUISE else 3),
                CRUISE_REST_WIDTH * cfg.sigma, X[:, :2])

    def predict(self, reference, filtered: bool = True) -> np.ndarray:
        """e_hat (T, n): the predicted error, zero on joints without networks and where no network is
        active; zero-phase low-passed at ``lowpass_hz`` unless ``filtered`` is False."""
        check_fitted(self, "networks_", hint="call fit(references, errors) before predict")
        T, n = reference.positions.shape
        out = np.zeros((T, n))
        self.outside_share_ = {}
        for j in self.joints:
            X, types, viable = self.inputs(reference, j)
            outside = viable & ~np.isfinite(X).all(axis=1)  # a v33 level without training data
            for t in self.types:
                sel = types == t
                if t not in self.networks_[j]:
                    outside |= sel  # too few training samples: no network
                elif sel.any():
                    x = self._network_inputs(t, X[sel])[3]
                    out[sel, j] = self.networks_[j][t].predict(x)
                    outside[sel] = self.networks_[j][t].outside(x)
            n_viable = int(viable.sum())
            self.outside_share_[j] = float(outside.sum()) / n_viable if n_viable else 0.0
        if filtered:
            out = lowpass_zero_phase(out, reference.fs, self.config_.lowpass_hz)
        return out

"""``PGNN``: fit on measured trials, predict feedforward (leaderboard methods in ``methods/pgnn/method.py``).

``PGNN.fit(trials)`` fits the physical model by least squares (``physics.model.PhysicalModel``,
the best physical-model fit that initializes zeta), then trains physical parameters and networks
jointly by Algorithm 1 (``pgnn.training``). ``predict(reference)`` gives f = f^M + f^C;
``use_network = False`` switches the network off at run time, leaving the trained physical
model as a working controller; ``nn_contribution(reference)`` is f^C alone.

A machine whose physical model carries effects (``System.model_effects``, a machine file's
``[[model]]`` tables) keeps them in f^M as the least-squares fit found them, held fixed: their
torque is taken off the target u before training (the network learns what the rigid body and they
leave) and added to f^M. Paper 000's Algorithm 1 trains zeta, the rigid body's parameters, through
the machine's ``inverse_dynamics``, which has no effect columns: training the effects' coefficients
too would need them in its physics features (``pgnn.objective``) and in R1's column space.

Saved files hold the weights (``torch.save`` of tensors only, loaded with ``weights_only=True``:
no arbitrary objects are unpickled) and a JSON header with the configuration and lcgym version.
"""

from __future__ import annotations

import dataclasses
import json
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import torch

from ... import systems
from ...data import atomic_write
from ...fitted import is_fitted
from ...physics.effects import effect_from_record, effect_record
from ...physics.kinematics import reference_kinematics, reference_positions
from ...physics.model import PhysicalModel
from ...provenance import __version__
from .network import PGNNModule
from .training import PGNNConfig, network_inputs, train, training_data


class PGNN:
    """Physics-guided neural network feedforward (paper 000) on any machine. Constructor arguments
    are stored as given; ``fit`` sets ``module_`` (the trained torch module), ``physical_`` (the
    least-squares physical model it started from) and ``info_`` (training history, epochs, seconds).

    system: the machine (a ``systems.System`` or a spec for ``systems.get``, such as "ix"; default
    the machine of ``physical``; one of the two is needed); config: default
    ``PGNNConfig.for_system(system)``. A ``physical`` model passed in is fitted in place (its
    ``params_`` become zeta^0); it must use the same sample rate ``fs`` [Hz] as the PGNN and the
    trials (checked). ``load`` restores ``module_`` only:
    ``physical_`` and ``info_`` belong to the fit and are not saved."""

    def __init__(self, config: PGNNConfig | None = None, fs: float = 500.0, physical: PhysicalModel | None = None,
                 system: systems.System | str | None = None):
        self.config = config
        self.fs = fs
        self.physical = physical
        self.system = system
        self.use_network = True

    @property
    def config_(self) -> PGNNConfig:
        if self.config is not None:
            return self.config
        return getattr(self, "_system_config", PGNNConfig())

    def fit(self, trials, progress: bool = False) -> PGNN:
        machine = self._machine()
        if self.config is None:
            self._system_config = PGNNConfig.for_system(machine)
        cfg = self.config_
        start = time.perf_counter()
        if self.physical is not None and abs(self.physical.fs - self.fs) > 1e-6 * self.fs:
            raise ValueError(f"physical model samples at {self.physical.fs} Hz, the PGNN at {self.fs} Hz")
        self.physical_ = (self.physical or machine.physical_model(fs=self.fs)).fit(trials)
        system = self.physical_.system
        zeta0 = self.physical_.params_.to_vector()
        self.fixed_ = self.physical_ if self.physical_.fitted_effects else None  # its effects, held fixed
        data = training_data(trials, system, cfg, zeta0[system.n_linear :],
                             fixed=None if self.fixed_ is None else self.fixed_.effects_torque)
        mean = data.inputs.mean(axis=0)
        std = np.maximum(data.inputs.std(axis=0), 1e-6)
        torch.manual_seed(cfg.seed)
        self.module_ = PGNNModule(system, zeta0, data.inputs.shape[1], cfg.hidden, cfg.activation,
                                  torch.tensor(mean, dtype=torch.float32), torch.tensor(std, dtype=torch.float32),
                                  cfg.zeta_steps, cfg.constraint_configs)
        left = None if cfg.max_seconds is None else cfg.max_seconds - (time.perf_counter() - start)
        self.info_ = train(self.module_, data, cfg, progress=progress, seconds=left)
        self.info_["fit_seconds"] = time.perf_counter() - start
        return self

    def _machine(self) -> systems.System:
        """The machine it learns on: ``system``, else the one of the ``physical`` model given."""
        if self.system is not None:
            return systems.get(self.system)
        if self.physical is not None:
            return self.physical.system
        raise ValueError("PGNN: give the machine, PGNN(system='ix') (a name, a .urdf file, module:attr or a System), "
                         "or a physical model, PGNN(physical=...)")

    @property
    def params_(self):
        """The physical parameters zeta after training (the machine's parameter class)."""
        return self.module_.system.params_from_vector(self.module_.zeta.detach().double().numpy())

    def _parts(self, reference) -> tuple[np.ndarray, np.ndarray]:
        q, qd, qdd = reference_kinematics(reference_positions(reference), self.fs, self.config_.advance)
        inputs = network_inputs(q, qd, qdd, self.config_, self.fs)
        tq = [torch.tensor(a, dtype=torch.float32) for a in (q, qd, qdd, inputs)]
        self.module_.network_on = self.use_network
        with torch.no_grad():
            f_m, f_c = self.module_(*tq)
        self.module_.network_on = True
        f_m = f_m.double().numpy()
        if getattr(self, "fixed_", None) is not None:  # the physical model's effects, held fixed
            f_m = f_m + self.fixed_.effects_torque(q, qd, qdd)
        return f_m, f_c.double().numpy()

    def predict(self, reference) -> np.ndarray:
        """Feedforward f = f^M + f^C (T, n_axes) [V for the IX] (f^M alone when ``use_network`` is False)."""
        f_m, f_c = self._parts(reference)
        return f_m + f_c

    def nn_contribution(self, reference) -> np.ndarray:
        """f^C (T, n_axes): what the network adds to the physical model."""
        return self._parts(reference)[1]

    def reference_offset(self, reference) -> np.ndarray | None:
        """The physical model's reference offset with the trained parameters (the arm's joint
        torsion, ``ArmModel.reference_offset``), or None for a system without one (the IX)."""
        if not is_fitted(self, "physical_") or not hasattr(self.physical_, "reference_offset"):
            return None
        return dataclasses.replace(self.physical_, params=self.params_).reference_offset(reference)

    def save(self, path: str | Path) -> Path:
        """Weights and configuration in one file (atomic write)."""
        path = Path(path)
        fixed = getattr(self, "fixed_", None)
        header = {"lcgym_version": __version__, "fs": self.fs, "config": asdict(self.config_),
                  "system": self.module_.system.name,
                  "n_inputs": int(self.module_.input_mean.numel()),
                  "effects": [] if fixed is None else [effect_record(e) for e in fixed.fitted_effects]}
        blob = {"header": torch.tensor(list(json.dumps(header).encode()), dtype=torch.uint8),
                **{f"state.{k}": v for k, v in self.module_.state_dict().items()}}
        atomic_write(path, lambda tmp: torch.save(blob, tmp))
        return path

    @classmethod
    def load(cls, path: str | Path, system: systems.System | None = None) -> PGNN:
        """Load a file written by ``save`` (tensors only; nothing else is unpickled). ``system``: the
        machine it was trained on (default the built-in machine the file names)."""
        blob = torch.load(Path(path), weights_only=True)
        header = json.loads(bytes(blob["header"].tolist()).decode())
        cfg = header["config"]
        cfg["hidden"], cfg["split"], cfg["history"] = tuple(cfg["hidden"]), tuple(cfg["split"]), tuple(cfg["history"])
        cfg["periods"] = tuple((int(a), float(p)) for a, p in cfg["periods"])
        config = PGNNConfig(**cfg)
        state = {k[len("state.") :]: v for k, v in blob.items() if k.startswith("state.")}
        machine = system or systems.get(header["system"])
        if machine.name != header["system"] or len(machine.param_names) != state["zeta0"].numel():
            raise ValueError(f"{path}: a PGNN of machine {header['system']!r} ({state['zeta0'].numel()} parameters), "
                             f"not of {machine.name!r} ({len(machine.param_names)})")
        self = cls(config, fs=header["fs"], system=machine)
        self.module_ = PGNNModule(machine, state["zeta0"].numpy(), header["n_inputs"], config.hidden, config.activation,
                                  zeta_steps=config.zeta_steps, constraint_configs=config.constraint_configs)
        self.module_.load_state_dict(state)
        effects = tuple(effect_from_record(r, machine) for r in header.get("effects", []))
        self.fixed_ = None if not effects else PhysicalModel(  # the fitted effects, on the least-squares zeta0
            machine, params=machine.params_from_vector(state["zeta0"].double().numpy()), effects=effects, fs=self.fs)
        return self

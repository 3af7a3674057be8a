"""The config of the risk-conditioned learners (``configs/risk_learner.yaml``)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["MODELS", "RiskLearnerConfig", "load_config"]

MODELS = ("boosting", "mlp")


@dataclass(frozen=True)
class RiskLearnerConfig:
    """The keys of ``configs/risk_learner.yaml`` (its comments say what each means)."""

    env_version: str = "v3"
    env_kwargs: dict[str, Any] = dataclasses.field(default_factory=lambda: {"experiments": "fixed"})
    structures: tuple[str, ...] = ("PID", "FPPI", "MSP", "PI")
    training_plants: int = 20000
    training_entropy: int = 3979327325554999766
    validation_plants: int = 1000
    validation_entropy: int = 12003775736600515953
    noise_range: tuple[float, float] = (0.003, 0.3)
    productions: tuple[float, ...] = (0.0, 0.05)
    quantized_share: float = 0.0
    quantization_range: tuple[float, float] = (0.1, 3.0)
    seed: int = 0
    models: tuple[str, ...] = ("boosting",)
    bands: tuple[int, ...] = (1, 4)
    quantized_band: tuple[bool, ...] = (False,)
    splits: tuple[float, float, float] = (0.6, 0.2, 0.2)

    def __post_init__(self) -> None:
        from agents.risk.labels import STRUCTURES

        unknown = [s for s in self.structures if s not in STRUCTURES]
        if unknown or not self.structures:
            raise ValueError(f"structures: unknown structure {unknown[0] if unknown else None!r}; valid: {', '.join(STRUCTURES)}")
        if not self.models or any(m not in MODELS for m in self.models):
            raise ValueError(f"models must be a list of {', '.join(MODELS)}, got {list(self.models)}")
        if not self.bands or any(int(b) != b or b < 1 for b in self.bands):
            raise ValueError(f"bands must be a list of integers >= 1, got {list(self.bands)}")
        if not (0 < self.noise_range[0] < self.noise_range[1]):
            raise ValueError(f"noise_range must be two increasing positive numbers, got {list(self.noise_range)}")
        if not self.quantized_band or any(not isinstance(q, bool) for q in self.quantized_band):
            raise ValueError(f"quantized_band must be a list of true/false, got {list(self.quantized_band)}")
        if len(self.splits) != 3 or any(s <= 0 for s in self.splits):
            raise ValueError(f"splits must be three positive shares, got {list(self.splits)}")
        if self.training_plants < 30 or self.validation_plants < 2:
            raise ValueError("training_plants must be at least 30 and validation_plants at least 2")
        if not 0 <= self.quantized_share <= 1:
            raise ValueError(f"quantized_share must be in [0, 1], got {self.quantized_share}")

    def env_id(self, structure: str) -> str:
        return f"DeadTime/{structure}-{self.env_version}"

    def draw_kwargs(self) -> dict[str, Any]:
        return {"noise_range": tuple(self.noise_range), "productions": tuple(self.productions),
                "quantized_share": self.quantized_share, "quantization_range": tuple(self.quantization_range)}

    def to_dict(self) -> dict[str, Any]:
        return {f.name: (list(v) if isinstance(v := getattr(self, f.name), tuple) else v) for f in dataclasses.fields(self)}


def load_config(path: str | Path, overrides: dict[str, Any] | None = None) -> RiskLearnerConfig:
    """The config of a YAML file (every key optional; an unknown key refused in one line), with ``overrides``."""
    from agents.files.reader import load_yaml_file

    data = {**(load_yaml_file(path, dict) or {}), **(overrides or {})}
    names = {f.name for f in dataclasses.fields(RiskLearnerConfig)}
    unknown = sorted(set(data) - names)
    if unknown:
        raise ValueError(f"{path}: unknown key {unknown[0]!r}; valid keys: {', '.join(sorted(names))}")
    tuples = {"structures", "noise_range", "productions", "quantization_range", "splits", "models", "bands", "quantized_band"}
    data = {k: tuple(v) if k in tuples and isinstance(v, list) else v for k, v in data.items()}
    try:
        return RiskLearnerConfig(**data)
    except TypeError as error:
        raise ValueError(f"{path}: {error}") from None

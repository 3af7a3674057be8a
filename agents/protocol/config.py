"""The schema of a protocol file (``configs/protocols/NAME.yaml``) and its fingerprint.

A protocol declares, before any of its test plants is evaluated, everything its answer depends on::

    name: v1
    seeds: {first: 0, count: 10}        # the training seeds of every learner
    alpha: 0.05                         # family-wise error rate of the comparisons (Holm)
    streams:
      validation: {entropy: 1234, plants: 2000, episode_seed: 50000000}
      test: {entropy: 5678, plants: 4000, episode_seed: 60000000}
    selection:
      violation_target: 0.01            # the certificate: plant-clustered upper bound <= target
      confidence: 0.95
      rules: [all-rules]                # the best rule: least mean validation cost among these
      plans: [plan-0.1-0.1, ...]        # the best single plan: likewise
      fixed_procedure: plan-1-1
    comparisons: [[fixed, best-rule], [plan, best-rule], [plan, fixed-procedure], [plan, best-plan]]
    regimes:
      - name: pid-noise01-time
        env: DeadTime/PID-v3
        env_kwargs: {noise_std: 0.01, weights: {production: 0}}
        fixed:                          # candidates of the fixed-mode primary (each list may be
                                        # empty or absent; a regime has one candidate at least)
          - {label: learned-fixed, config: configs/learned_plan.yaml, overrides: [], origin: configs/sweeps/X.yaml}
        plan: [...]                     # candidates of the plan-mode primary (may be empty)
        seq: [...]                      # candidates of the sequential primary (may be empty)

A frontier protocol (:mod:`agents.protocol.frontier_run`) has a ``frontier`` section instead of
``selection`` and ``comparisons``: every rule and every candidate learner is a family by its risk knob,
and its comparisons are fixed by the section::

    frontier:
      knobs: [-1, -0.5, -0.25, 0, 0.25, 0.5, 1, 1.5, 2]   # increasing, 0 (the shipped policy) among them
      risk_levels: [0.005, 0.01, 0.02, 0.05]
      rules: [all-rules]              # the rule families (a regime's own ``rules:`` list replaces it there)
      min_seeds: 10                   # seeds.count at least this
    regimes:
      - {name: ..., env: ..., env_kwargs: ..., rules: [...], fixed: [...], plan: [...],
         pretrained: [learned-pid@0.01, ...]}   # every candidate a family

A learner's label there names neither a rule nor holds ``@`` (``FAMILY@S`` names a family's member).
``pretrained`` names shipped learners of the regime's structure at a risk (:mod:`agents.risk.pretrained`):
each is a learned family of one model (the shipped file, not trained by the protocol).

Streams of plants (:mod:`agents.protocol.streams`): the validation and test plants of each structure
come from ``numpy.random.SeedSequence(entropy, spawn_key=(family,))``; the training plants are the
learners' own (their configs' seeds, :mod:`agents.training.learned_rule`).  The test entropy must be
registered in ``configs/protocols/test_seeds.json`` with this file's sha256 before the run.

The file is read with :func:`agents.files.reader.load_yaml_file`; an unknown key is an error that
names it.  Every name is checked here, before anything is trained: the protocol's, each regime's and
each label a plain file name (:func:`agents.files.names.plain_name`: they name folders of the run);
``selection.rules`` rule names or ``all-rules`` (the oracle, a plan or a learner is not a rule);
``selection.plans`` and ``fixed_procedure`` procedures fixed in advance (``plan-A1-A2`` in range or
``amplitude-rule``); each declared comparison made in one regime at least (:func:`comparison_problem`).  :attr:`Protocol.sha256` is the SHA-256 of the file's bytes: any change to the file
(a comment too) is a changed protocol.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from agents.limits import MAX_SEEDS, MAX_TEST_PLANTS, require_at_most
from agents.files.names import plain_name
from agents.files.reader import load_yaml_file
from agents.training.schema import integer_field as _integer, mapping_field as _mapping

if TYPE_CHECKING:
    from agents.sweeps.config import Trial

__all__ = ["COMPARISON_SIDES", "PRIMARIES", "Frontier", "Learner", "Protocol", "Regime", "Selection", "Stream", "comparison_problem",
           "load_protocol", "structure_and_family", "trial"]

PRIMARIES: tuple[str, ...] = ("fixed", "plan", "seq")
"""The primaries a regime may have: the fixed mode's learned design, the plan mode's (experiments
planned before the first measurement) and the sequential agent's (the next experiment chosen from the
last one's record; ``configs/sequential.yaml``)."""
COMPARISON_SIDES = {"first": PRIMARIES, "second": ("best-rule", "base-rule", "fixed-procedure", "best-plan", *PRIMARIES)}
"""What a declared comparison may name: a primary first; second a baseline chosen on validation,
``base-rule``, the structure's own rule (:attr:`envs.structures.Structure.base_rule`, fixed in advance),
or another primary."""


@dataclass(frozen=True)
class Learner:
    """A candidate learner: a training config with overrides, as a sweep trial declares it."""

    label: str
    config: str
    overrides: tuple[str, ...] = ()
    origin: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {"label": self.label, "config": self.config, "overrides": list(self.overrides), "origin": self.origin}


@dataclass(frozen=True)
class Regime:
    """One environment in one regime, with the candidates of its two primaries."""

    name: str
    env: str
    env_kwargs: Mapping[str, Any]
    fixed: tuple[Learner, ...]
    plan: tuple[Learner, ...] = ()
    seq: tuple[Learner, ...] = ()
    rules: tuple[str, ...] = ()
    pretrained: tuple[str, ...] = ()

    def learners(self) -> tuple[Learner, ...]:
        """Every candidate of every primary, in order (a frontier protocol's learned families)."""
        return (*self.fixed, *self.plan, *self.seq)

    def candidates(self, mode: str) -> tuple[Learner, ...]:
        return {"fixed": self.fixed, "plan": self.plan, "seq": self.seq}[mode]


@dataclass(frozen=True)
class Stream:
    """A stream of plants per structure: its entropy, its size and the first episode seed."""

    entropy: int
    plants: int
    episode_seed: int


@dataclass(frozen=True)
class Selection:
    """How the primaries, the best rule and the best plan are chosen on the validation plants."""

    violation_target: float = 0.01
    confidence: float = 0.95
    rules: tuple[str, ...] = ("all-rules",)
    plans: tuple[str, ...] = ()
    fixed_procedure: str = "plan-1-1"


@dataclass(frozen=True)
class Frontier:
    """A frontier protocol's declaration (module docstring): the knob grid, the risk levels and the rule families."""

    knobs: tuple[float, ...]
    risk_levels: tuple[float, ...] = (0.005, 0.01, 0.02, 0.05)
    rules: tuple[str, ...] = ("all-rules",)
    min_seeds: int = 10


@dataclass(frozen=True)
class Protocol:
    """A protocol file, read and checked (module docstring)."""

    name: str
    path: str
    sha256: str
    seeds: tuple[int, ...]
    alpha: float
    validation: Stream
    test: Stream
    selection: Selection
    comparisons: tuple[tuple[str, str], ...]
    regimes: tuple[Regime, ...] = field(default_factory=tuple)
    frontier: Frontier | None = None

    def regime(self, name: str) -> Regime:
        for regime in self.regimes:
            if regime.name == name:
                return regime
        raise ValueError(f"{self.path}: no regime named {name!r} (regimes: {', '.join(r.name for r in self.regimes)})")


# ------------------------------------------------------------------------------------ reading
def _fraction(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value < 1:
        raise ValueError(f"{where} must be a number in (0, 1), got {value!r}")
    return float(value)


def _strings(value: Any, where: str, allow_empty: bool = False) -> tuple[str, ...]:
    if value is None and allow_empty:
        return ()
    if not isinstance(value, list) or (not value and not allow_empty) or not all(isinstance(v, str) and v for v in value):
        raise ValueError(f"{where} must be a list of non-empty strings, got {value!r}")
    return tuple(value)


def _seeds(value: Any) -> tuple[int, ...]:
    value = _mapping(value, "seeds", ("first", "count"), ("count",))
    first, count = _integer(value.get("first", 0), "seeds.first", 0), _integer(value["count"], "seeds.count", 1)
    require_at_most(count, MAX_SEEDS, "seeds.count")
    return tuple(range(first, first + count))


def _stream(value: Any, where: str) -> Stream:
    value = _mapping(value, where, ("entropy", "plants", "episode_seed"), ("entropy", "plants", "episode_seed"))
    plants = _integer(value["plants"], f"{where}.plants", 2)
    require_at_most(plants, MAX_TEST_PLANTS, f"{where}.plants")
    return Stream(_integer(value["entropy"], f"{where}.entropy", 0), plants, _integer(value["episode_seed"], f"{where}.episode_seed", 0))


def _selection(value: Any) -> Selection:
    value = _mapping(value, "selection", ("violation_target", "confidence", "rules", "plans", "fixed_procedure"),
                     ("violation_target", "confidence", "rules"))
    rules = _strings(value["rules"], "selection.rules")
    for i, name in enumerate(rules):
        _rule(name, f"selection.rules[{i}]")
    plans = _strings(value.get("plans"), "selection.plans", allow_empty=True)
    for i, name in enumerate(plans):
        _procedure(name, f"selection.plans[{i}]")
    procedure = _procedure(value.get("fixed_procedure", Selection.fixed_procedure), "selection.fixed_procedure")
    for where, names in (("selection.rules", rules), ("selection.plans", plans)):
        if len(set(names)) != len(names):
            raise ValueError(f"{where} names {sorted(n for n in names if names.count(n) > 1)[0]!r} twice")
    return Selection(_fraction(value["violation_target"], "selection.violation_target"),
                     _fraction(value["confidence"], "selection.confidence"), rules, plans, procedure)


def _rule(name: str, where: str) -> str:
    """``name`` if it names a rule of :mod:`baselines.rules.registry` or is ``all-rules``."""
    import difflib

    from baselines.rules.registry import RULES

    if name == "all-rules" or name in RULES:
        return name
    close = difflib.get_close_matches(name, ["all-rules", *RULES], n=1)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    raise ValueError(f"{where}: {name!r} is not a rule{hint}; the best rule is chosen among rule names of "
                     "baselines/rules or all-rules (the oracle, plans and learners are not rules)")


def _procedure(name: Any, where: str) -> str:
    """``name`` if it names a procedure fixed in advance: ``plan-A1-A2`` (amplitudes in range) or ``amplitude-rule``."""
    from baselines.procedures import BEST_PLAN, is_procedure, procedure

    if not isinstance(name, str) or not is_procedure(name) or name == BEST_PLAN:
        raise ValueError(f"{where}: {name!r} is not a procedure fixed in advance (plan-A1-A2, e.g. plan-1-1, or amplitude-rule)")
    try:
        procedure(name)
    except ValueError as error:
        raise ValueError(f"{where}: {error}") from None
    return name


def _learner(value: Any, where: str) -> Learner:
    value = _mapping(value, where, ("label", "config", "overrides", "origin"), ("label", "config"))
    label, config = plain_name(value["label"], f"{where}.label", also="=,"), value["config"]
    if not isinstance(config, str) or not Path(config).is_file():
        raise ValueError(f"{where}.config: no such file: {config!r}")
    origin = value.get("origin", "")
    if not isinstance(origin, str):
        raise ValueError(f"{where}.origin must be a string, got {origin!r}")
    return Learner(label, config, _strings(value.get("overrides"), f"{where}.overrides", allow_empty=True), origin)


def _regime(value: Any, where: str, frontier: bool = False) -> Regime:
    value = _mapping(value, where, ("name", "env", "env_kwargs", *PRIMARIES, *(("rules", "pretrained") if frontier else ())),
                     ("name", "env"))
    name, env = plain_name(value["name"], f"{where}.name"), value["env"]
    if not isinstance(env, str) or not env.startswith("DeadTime/"):
        raise ValueError(f"{where}.env must be a DeadTime environment id, got {env!r}")
    env_kwargs = value.get("env_kwargs") or {}
    if not isinstance(env_kwargs, Mapping) or "experiments" in env_kwargs:
        raise ValueError(f"{where}.env_kwargs must be a mapping of environment arguments without 'experiments', got {env_kwargs!r}")
    learners = {}
    for mode in PRIMARIES:
        items = value.get(mode) or []
        if not isinstance(items, list):
            raise ValueError(f"{where}.{mode} must be a list of learners")
        learners[mode] = tuple(_learner(item, f"{where}.{mode}[{i}]") for i, item in enumerate(items))
        labels = [learner.label for learner in learners[mode]]
        if len(set(labels)) != len(labels):
            raise ValueError(f"{where}.{mode} repeats a label: {labels}")
    labels = [learner.label for mode in PRIMARIES for learner in learners[mode]]
    pretrained = _strings(value.get("pretrained"), f"{where}.pretrained", allow_empty=True)
    if not labels and not pretrained:
        raise ValueError(f"{where} has no candidates: give at least one of {', '.join(PRIMARIES)} a learner")
    shared = sorted({label for label in labels if labels.count(label) > 1})
    if shared:
        raise ValueError(f"{where}: the label {shared[0]!r} names candidates of two primaries; give them distinct labels")
    rules = _strings(value.get("rules"), f"{where}.rules", allow_empty=True)
    for i, rule in enumerate(rules):
        _rule(rule, f"{where}.rules[{i}]")
    regime = Regime(name, env, dict(env_kwargs), learners["fixed"], learners["plan"], learners["seq"], rules, pretrained)
    if pretrained:
        _check_pretrained(regime, f"{where}.pretrained")
    return regime


def _check_pretrained(regime: Regime, where: str) -> None:
    """Each name of ``regime.pretrained`` a shipped learner of the regime's structure at a risk, loaded, no repeat."""
    from agents.risk.pretrained import load_pretrained

    if len(set(regime.pretrained)) != len(regime.pretrained):
        raise ValueError(f"{where} repeats a name: {list(regime.pretrained)}")
    structure, _ = structure_and_family(regime)
    for i, name in enumerate(regime.pretrained):
        try:
            load_pretrained(name, structure)
        except ValueError as error:
            raise ValueError(f"{where}[{i}]: {error}") from None


def _frontier(value: Any) -> Frontier:
    """The ``frontier`` section: ``knobs`` (finite, ``|s|`` at most the rules' limit, 0 among them), ``risk_levels``
    (increasing, in (0, 1)), ``rules`` (rule names or ``all-rules``), ``min_seeds`` (the least seeds a learner takes)."""
    from baselines.rules.family import KNOB_LIMIT

    value = _mapping(value, "frontier", ("knobs", "risk_levels", "rules", "min_seeds"), ("knobs", "risk_levels"))
    knobs = value["knobs"]
    if (not isinstance(knobs, list) or not knobs or
            not all(not isinstance(k, bool) and isinstance(k, (int, float)) and abs(k) <= KNOB_LIMIT for k in knobs)):
        raise ValueError(f"frontier.knobs must be a list of numbers from -{KNOB_LIMIT:g} to {KNOB_LIMIT:g}, got {knobs!r}")
    if sorted(set(knobs)) != knobs or 0 not in knobs:
        raise ValueError(f"frontier.knobs must be increasing, without repeats, and hold 0 (the shipped policy), got {knobs!r}")
    levels = value["risk_levels"]
    if not isinstance(levels, list) or not levels:
        raise ValueError(f"frontier.risk_levels must be a non-empty list, got {levels!r}")
    levels = [_fraction(level, f"frontier.risk_levels[{i}]") for i, level in enumerate(levels)]
    if sorted(set(levels)) != levels:
        raise ValueError(f"frontier.risk_levels must be increasing, without repeats, got {levels!r}")
    rules = _strings(value.get("rules", ["all-rules"]), "frontier.rules")
    for i, name in enumerate(rules):
        _rule(name, f"frontier.rules[{i}]")
    min_seeds = _integer(value.get("min_seeds", Frontier.min_seeds), "frontier.min_seeds", 2)
    return Frontier(tuple(float(k) for k in knobs), tuple(levels), rules, min_seeds)


def _comparisons(value: Any) -> tuple[tuple[str, str], ...]:
    if not isinstance(value, list) or not value:
        raise ValueError(f"comparisons must be a non-empty list of [first, second] pairs, got {value!r}")
    pairs = []
    for i, pair in enumerate(value):
        if (not isinstance(pair, list) or len(pair) != 2 or pair[0] not in COMPARISON_SIDES["first"]
                or pair[1] not in COMPARISON_SIDES["second"] or pair[0] == pair[1]):
            raise ValueError(f"comparisons[{i}] must be [first, second] with first one of {COMPARISON_SIDES['first']} "
                             f"and second another of {COMPARISON_SIDES['second']}, got {pair!r}")
        if tuple(pair) in pairs:
            raise ValueError(f"comparisons[{i}] declares {pair!r} a second time")
        pairs.append((pair[0], pair[1]))
    return tuple(pairs)


def _check_comparisons(protocol: Protocol) -> None:
    """Each declared comparison made in one regime at least (:func:`comparison_problem`)."""
    for i, pair in enumerate(protocol.comparisons):
        problems = [comparison_problem(protocol, regime, pair) for regime in protocol.regimes]
        if all(problems):
            raise ValueError(f"{protocol.path}: comparisons[{i}] {list(pair)} is made in no regime ({problems[0]})")


def comparison_problem(protocol: Protocol, regime: Regime, pair: tuple[str, str]) -> str | None:
    """Why ``regime`` cannot make the declared comparison ``pair`` (None if it makes it): a primary
    without candidates there, or ``best-plan`` without declared plans."""
    for role in pair:
        if role in PRIMARIES and not regime.candidates(role):
            return f"the regime has no {role} candidates"
    if "best-plan" in pair and not protocol.selection.plans:
        return "selection.plans is empty"
    return None


def load_protocol(path: str | Path) -> Protocol:
    """Read and check a protocol file.

    Raises
    ------
    ValueError
        Naming the file, key or value that is wrong (an unknown key, a missing config, two regimes of
        one name, equal validation and test entropies, a learner whose training config does not resolve).
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"protocol {path}: no such file")
    sha256 = hashlib.sha256(path.read_bytes()).hexdigest()
    data = load_yaml_file(path) or {}
    if isinstance(data, Mapping) and "frontier" in data:
        return _load_frontier(path, sha256, data)
    data = _mapping(data, str(path),
                    ("name", "seeds", "alpha", "streams", "selection", "comparisons", "regimes"),
                    ("name", "seeds", "alpha", "streams", "selection", "comparisons", "regimes"))
    name, validation, test, regimes = _common(path, data, frontier=False)
    protocol = Protocol(name, str(path), sha256, _seeds(data["seeds"]), _fraction(data["alpha"], "alpha"), validation, test,
                        _selection(data["selection"]), _comparisons(data["comparisons"]), regimes)
    _check_comparisons(protocol)
    _check_learners(protocol)
    return protocol


def _common(path: Path, data: Mapping[str, Any], frontier: bool) -> tuple[str, Stream, Stream, tuple[Regime, ...]]:
    """The name, the two streams and the regimes, checked."""
    name = plain_name(data["name"], f"{path}: name")
    streams = _mapping(data["streams"], "streams", ("validation", "test"), ("validation", "test"))
    validation, test = _stream(streams["validation"], "streams.validation"), _stream(streams["test"], "streams.test")
    if validation.entropy == test.entropy:
        raise ValueError(f"{path}: streams.validation and streams.test must have different entropies, both are {test.entropy}")
    if not isinstance(data["regimes"], list) or not data["regimes"]:
        raise ValueError(f"{path}: regimes must be a non-empty list")
    regimes = tuple(_regime(item, f"regimes[{i}]", frontier) for i, item in enumerate(data["regimes"]))
    names = [regime.name for regime in regimes]
    if len(set(names)) != len(names):
        raise ValueError(f"{path}: two regimes have one name: {sorted(n for n in set(names) if names.count(n) > 1)[0]!r}")
    return name, validation, test, regimes


def _load_frontier(path: Path, sha256: str, data: Mapping[str, Any]) -> Protocol:
    """A frontier protocol (module docstring): no ``selection`` nor ``comparisons``, a ``frontier`` section."""
    data = _mapping(data, str(path), ("name", "seeds", "alpha", "streams", "frontier", "regimes"),
                    ("name", "seeds", "alpha", "streams", "frontier", "regimes"))
    name, validation, test, regimes = _common(path, data, frontier=True)
    frontier = _frontier(data["frontier"])
    seeds = _seeds(data["seeds"])
    if len(seeds) < frontier.min_seeds:
        raise ValueError(f"{path}: seeds.count is {len(seeds)}, frontier.min_seeds asks for {frontier.min_seeds} at least")
    for regime in regimes:
        labels = [learner.label for learner in regime.learners()]
        rules = regime.rules or frontier.rules
        if set(labels) & set(rules) or any("@" in label for label in labels):
            raise ValueError(f"{path}, regime {regime.name}: a learner's label must not name a rule nor hold '@', got {labels}")
    protocol = Protocol(name, str(path), sha256, seeds, _fraction(data["alpha"], "alpha"), validation, test,
                        Selection(rules=frontier.rules), (), regimes, frontier)
    _check_learners(protocol)
    return protocol


def _check_learners(protocol: Protocol) -> None:
    """Each learner's training config resolved and validated for its regime, as ``deadtime train`` would."""
    from agents.training.config import validate

    for regime in protocol.regimes:
        for mode in PRIMARIES:
            for learner in regime.candidates(mode):
                try:
                    validate(trial(regime, learner, protocol.seeds[0]).train_config(Path("unused")))
                except ValueError as error:
                    raise ValueError(f"{protocol.path}, regime {regime.name}, learner {learner.label}: {error}") from None


def trial(regime: Regime, learner: Learner, seed: int) -> Trial:
    """The sweep trial of ``learner`` in ``regime`` with ``seed``."""
    from agents.sweeps.config import Trial

    return Trial(learner.label, regime.env, seed, learner.config, learner.overrides, dict(regime.env_kwargs))


def structure_and_family(regime: Regime) -> tuple[str, str]:
    """The name of the regime's structure and its plant family (from one environment, made and closed)."""
    from agents.environments import make_env
    from envs.interface import tuning_env_of

    env = make_env(regime.env, {"experiments": "fixed", **regime.env_kwargs})
    found = tuning_env_of(env).structure, tuning_env_of(env).family
    env.close()
    return found

"""The protocol's work as tasks (:mod:`agents.protocol.tasks`): chunks of a stream scored as one evaluation
scores the stream; the fits a run needs, each once; where the tasks run (:mod:`agents.protocol.workers`)."""

from __future__ import annotations

from pathlib import Path

import pytest

from agents.evaluation.evaluate import evaluate
from agents.protocol.config import Learner, Regime
from agents.protocol.run import _unique
from agents.protocol.streams import plant_stream
from agents.protocol.tasks import Fit, chunks, merge_chunks
from agents.protocol.workers import workers

REGIME = Regime("tiny", "DeadTime/PID-v3", {"noise_std": 0.01}, ())


def test_the_chunks_cover_the_stream_in_order_with_the_benchmark_batch_in_the_first(tmp_path: Path) -> None:
    plants = plant_stream("fopdt", 11, 7)
    parts = chunks(REGIME, "test", ["simc-pi", "oracle"], plants, 500, tmp_path, True, 3)
    assert [(part.first, len(part.plants), part.benchmark) for part in parts] == [(0, 3, True), (3, 3, False), (6, 1, False)]
    assert [plant for part in parts for plant in part.plants] == [plant.to_dict() for plant in plants]
    assert {part.episode_seed for part in parts} == {500}  # each chunk is evaluated from 500 + first
    assert len({part.directory for part in parts}) == 3
    assert not any(part.benchmark for part in chunks(REGIME, "validation", ["oracle"], plants, 500, tmp_path, False, 3))


def test_chunks_merged_are_one_evaluation_of_the_whole_stream_byte_for_byte(tmp_path: Path) -> None:
    """The test plants' episode seeds, labels and indices, and the benchmark batch's, are those of one
    evaluation: the protocol's tables do not depend on the chunk size."""
    plants = plant_stream("fopdt", 11, 5)
    evaluate(REGIME.env, "simc-pi,oracle", 5, 700, tmp_path / "whole", benchmark=True, resamples=100, plots=False,
             plants=[plant.to_dict() for plant in plants], env_kwargs=dict(REGIME.env_kwargs))
    parts = chunks(REGIME, "test", ["simc-pi", "oracle"], plants, 700, tmp_path / "parts", True, 2)
    with workers(1) as run:
        assert run(parts) == [part.directory for part in parts]
    merge_chunks(parts, tmp_path / "merged.csv")
    whole = (tmp_path / "whole" / "per_plant.csv").read_text()
    assert "benchmark" in whole and "user-4" in whole
    assert (tmp_path / "merged.csv").read_text() == whole


def test_a_fit_needed_by_two_regimes_or_two_stages_is_one_task(tmp_path: Path) -> None:
    config = tmp_path / "rule.yaml"
    config.write_text("default: {algorithm: learned-rule}\n")
    learner = Learner("rule", str(config))
    other = Regime("other", REGIME.env, dict(REGIME.env_kwargs), ())  # the same environment and regime: the same fits
    noisier = Regime("noisier", REGIME.env, {"noise_std": 0.1}, ())
    fits = [Fit(str(tmp_path), regime, learner, seed) for regime in (REGIME, other, noisier, REGIME) for seed in (0, 1)]
    assert [(fit.regime.name, fit.seed) for fit in _unique(fits)] == [("tiny", 0), ("tiny", 1), ("noisier", 0), ("noisier", 1)]


def test_tasks_pickle_as_ray_sends_them(tmp_path: Path) -> None:
    import pickle

    part = chunks(REGIME, "test", ["oracle"], plant_stream("fopdt", 11, 2), 0, tmp_path, True)[0]
    fit = Fit(str(tmp_path), REGIME, Learner("rule", "rule.yaml"), 0)
    assert pickle.loads(pickle.dumps([part, fit])) == [part, fit]


def test_negative_workers_are_refused_in_one_line() -> None:
    with pytest.raises(ValueError, match="--workers must be >= 0"), workers(-1):
        pass


def test_a_task_runs_in_process_with_one_worker_or_none(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """No Ray for a serial run: a failing task's error is the task's own."""
    import sys

    monkeypatch.setitem(sys.modules, "ray", None)  # an import of ray would fail
    for count in (0, 1):
        with workers(count) as run:
            assert run([]) == []
    with pytest.raises(ValueError, match="needs Ray"), workers(2):
        pass


class _FakeRay:
    """Ray's calls as the runner makes them, the tasks finishing in the reverse order of submission."""

    class exceptions:  # noqa: N801  (as ray.exceptions)
        class RayError(Exception):
            pass

    def remote(self, **options: object):
        def wrap(function):
            class Remote:
                @staticmethod
                def remote(*args: object) -> tuple:
                    return ("ref", args)

            return Remote

        return wrap

    def wait(self, pending: list, num_returns: int, timeout: float) -> tuple[list, list]:
        return [pending[-1]], pending[:-1]

    def get(self, ref: tuple) -> str:
        task = ref[1][1]
        if task == "broken":
            raise self.exceptions.RayError("Traceback ...\nValueError: no such rule")
        return f"{task}-result"


class _Named(str):
    @property
    def name(self) -> str:
        return f"task {self}"


def test_on_ray_the_results_come_in_the_order_of_the_tasks_whatever_order_they_finish_in() -> None:
    from agents.protocol.workers import _on_ray

    run = _on_ray(_FakeRay())
    assert run([_Named("a"), _Named("b"), _Named("c")]) == ["a-result", "b-result", "c-result"]
    with pytest.raises(ValueError, match=r"^task broken failed: RayError: ValueError: no such rule \(the finished"):
        run([_Named("a"), _Named("broken")])

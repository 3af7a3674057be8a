"""``python -m agents.warmup`` (run by ``make install``) plays its episodes without error."""

from agents.warmup import warm_up


def test_the_warm_up_plays_every_structure_and_mode():
    assert warm_up() > 0

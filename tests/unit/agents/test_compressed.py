"""Result files read by their plain name, stored plain or gzip-compressed (agents/compressed.py)."""

from __future__ import annotations

import csv
import gzip

import pytest

from agents.compressed import compress_file, compressed_bytes, exists, open_text, read_json, read_text, stored_path

TABLE = "index,plant,cost\n0,a,1.5\n1,b,2.25\n"


def test_the_plain_and_the_compressed_file_read_the_same(tmp_path):
    plain, packed = tmp_path / "plain" / "per_plant.csv", tmp_path / "packed" / "per_plant.csv"
    plain.parent.mkdir(), packed.parent.mkdir()
    plain.write_text(TABLE)
    packed.with_name("per_plant.csv.gz").write_bytes(gzip.compress(TABLE.encode()))
    for path in (plain, packed):
        assert exists(path) and read_text(path) == TABLE
        with open_text(path) as file:
            assert [row["cost"] for row in csv.DictReader(file)] == ["1.5", "2.25"]
    assert stored_path(packed).name == "per_plant.csv.gz" and stored_path(plain) == plain


def test_a_missing_file_is_named_by_its_plain_name(tmp_path):
    assert not exists(tmp_path / "results.json")
    with pytest.raises(FileNotFoundError, match="results.json"):
        read_json(tmp_path / "results.json")


def test_compressing_gives_the_same_bytes_every_time(tmp_path):
    """Modification time 0 and no file name in the header: the same text, the same bytes."""
    data = b'{"a": 1}\n'
    assert compressed_bytes(data) == compressed_bytes(data) and compressed_bytes(data)[4:8] == b"\0\0\0\0"
    path = tmp_path / "summary.json"
    path.write_bytes(data)
    target = compress_file(path)
    assert target.name == "summary.json.gz" and not path.exists()
    assert target.read_bytes() == compressed_bytes(data) and read_json(path) == {"a": 1}

"""Files read and written by ``deadtime``: one reader, one atomic writer, one folder lock.

* :mod:`agents.files.reader` reads every YAML, JSON and CSV file within bounds and turns any
  problem into one line naming the file (:class:`FileProblem`, a ``ValueError``);
* :mod:`agents.files.writer` writes every result file atomically (a temporary file in the same
  folder, flushed to disk, moved into place);
* :mod:`agents.files.lock` holds an output folder for the whole of a run.
"""

from agents.files.reader import DamagedFileError, FileProblem

__all__ = ["DamagedFileError", "FileProblem"]

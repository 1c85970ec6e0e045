"""Running a robot-description parser (URDF, MJCF) and naming its failure.

urdfdom writes its complaint (the XML error, the element it could not read) to the process's standard
error from C++ and raises only "does not contain a valid URDF model". The parse runs with file
descriptor 2 sent to a temporary file, so that the complaint becomes part of the :class:`URDFError`
instead of text printed before it; on success, whatever the parser wrote is passed on unchanged.
"""

from __future__ import annotations

import os
import sys
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..errors import URDFError

__all__ = ["parse_file"]

# the redirection of fd 2 is process-wide: one parse at a time
_LOCK = threading.Lock()


def parse_file(kind: str, build: Callable[[str], Any], path: Path) -> Any:
    """``build(str(path))``, a parser's failure raised as a :class:`URDFError` with its complaint.

    Raises
    ------
    URDFError
        The parser raised: the message gives the path, the parser's exception and what it wrote to
        standard error.
    """
    with _LOCK:
        try:
            sys.stderr.flush()
            saved = os.dup(2)
        except (OSError, ValueError, AttributeError):  # no usable fd 2 (an embedded interpreter): parse as is
            saved = -1
        with tempfile.TemporaryFile() as sink:
            if saved >= 0:
                os.dup2(sink.fileno(), 2)
            try:
                model = build(str(path))
                error: Exception | None = None
            except (RuntimeError, ValueError) as exc:
                model, error = None, exc
            finally:
                if saved >= 0:
                    os.dup2(saved, 2)
                    os.close(saved)
            sink.seek(0)
            said = sink.read().decode("utf-8", "replace").strip()
    if error is None:
        if said:  # warnings of a successful parse are the user's to see
            print(said, file=sys.stderr)
        return model
    complaint = " ".join(said.split()) if said else ""
    raise URDFError(f"could not parse {kind} file {str(path)!r}: {error}"
                    + (f"; the parser said: {complaint}" if complaint else "")) from error

"""The long commands' progress display: drawn on a terminal only, and counting every step."""

from __future__ import annotations

import io

from mbimpact.apps.progress import Progress, track


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_pipe_or_a_log_file_gets_no_progress_output():
    stream = io.StringIO()
    bar = Progress(3, "job", stream=stream)
    for _ in range(3):
        bar.step("x")
    assert not bar.enabled and bar.done == 3 and stream.getvalue() == ""


def test_a_terminal_sees_the_label_and_the_count_of_steps_done():
    stream = _Terminal()
    bar = Progress(2, "job", stream=stream)
    bar.step("first")
    bar.step("second")
    text = stream.getvalue()
    assert bar.enabled and "job" in text and "2/2" in text


def test_no_progress_turns_a_terminal_display_off():
    stream = _Terminal()
    bar = Progress(2, "job", stream=stream, enabled=False)
    bar.step()
    assert stream.getvalue() == ""


def test_track_yields_every_item_in_order():
    assert list(track(iter(range(5)), "items", total=5)) == [0, 1, 2, 3, 4]

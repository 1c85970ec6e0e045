"""Fuzzing the command line: any argv ends with an exit status and a message, never a traceback.

Each example builds an argv for :func:`mbimpact.apps.cli.main` from a grammar of the commands
(``demo``, ``compare``, ``run``, ``scene``, ``fit``, ``figures``, ``bench``) with options drawn
from valid and bad values — unknown options, numbers that are not numbers, NaN, inf, negative or
huge counts, postures of the wrong length, unwritable or existing ``--out`` paths, missing or
malformed scene and data files, null bytes — plus random tokens. Runs that would take long
(``bench``, ``figures`` writing every figure, ``fit`` with its default laws) are only given bad
arguments. Asserted, with stdout and stderr captured:

* the call returns an exit status within :data:`LIMIT` (0 success, 2 a mistake in the input,
  3 a simulation that did not complete) or exits through argparse with 0 or 2;
* nothing escapes ``main`` (no exception of any kind) and stderr holds no traceback;
* a non-zero status comes with a message on stderr.

The default run takes a small derandomised sample; ``pytest -m slow`` runs 10⁴ examples.
"""

from __future__ import annotations

import io
import os
import warnings
from collections.abc import Iterator
from contextlib import redirect_stderr, redirect_stdout

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mbimpact.apps.cli import main
from tests.helpers import time_limit

LIMIT = 60.0  # seconds per command

PENDULUM = """<?xml version="1.0"?>
<robot name="pendulum">
  <link name="base"/>
  <link name="arm"><inertial><origin xyz="0 0 -0.5"/><mass value="1.0"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="arm"/><origin xyz="0 0 1"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="10"/></joint>
  <link name="tip"/>
  <joint name="tip_joint" type="fixed"><parent link="arm"/><child link="tip"/><origin xyz="0 0 -1"/></joint>
</robot>
"""
SCENE = """name = "tiny"
[mechanism]
model = "point_mass_3d"
[initial]
q = [0.0, 0.0, 0.05]
v = [0.3, 0.0, 0.0]
[[contacts]]
frame = "mass"
roughness = { kind = "cone", alpha = 0.2 }
e = 0.7
friction = 0.3
[simulation]
duration = 0.2
"""
TABLE = "theta_deg,kappa\n0,0.8\n30,0.7\n60,0.6\n"


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> Iterator[dict[str, str]]:
    """Paths the grammar refers to: good and bad inputs, and outputs of every kind. The commands run
    in this folder: relative --out paths (and ./figures) are written here, not in the repository."""
    root = tmp_path_factory.mktemp("cli")
    cwd = os.getcwd()
    os.chdir(root)
    (root / "pendulum.urdf").write_text(PENDULUM)
    (root / "broken.urdf").write_text("<robot name='x'><link")
    (root / "tiny.toml").write_text(SCENE)
    (root / "typo.toml").write_text(SCENE.replace("duration", "duraton"))
    (root / "nan.toml").write_text(SCENE.replace("0.05]", "nan]"))
    (root / "notoml.toml").write_text("[[[ this is not TOML")
    (root / "table.csv").write_text(TABLE)
    (root / "bad.csv").write_text("theta_deg,kappa\n0,zero\n")
    (root / "empty.csv").write_text("")
    (root / "file").write_text("x")
    (root / "dir").mkdir()
    names = ("pendulum.urdf", "broken.urdf", "tiny.toml", "typo.toml", "nan.toml", "notoml.toml", "table.csv",
             "bad.csv", "empty.csv", "file", "dir")
    out = {name: str(root / name) for name in names}
    try:
        yield out | {"new": str(root / "new"), "under_file": str(root / "file" / "sub")}
    finally:
        os.chdir(cwd)


def numbers(good: list[str]) -> st.SearchStrategy[str]:
    """A valid value half the time, else one that is not a valid number for it."""
    return st.sampled_from(good) | st.sampled_from(["nan", "inf", "-inf", "-1", "0", "1e308", "-1e308", "1e-320", "abc",
                                                    "", "1,2", "0x10", "1e", "--"])


def counts(good: list[str]) -> st.SearchStrategy[str]:
    return st.sampled_from(good) | st.sampled_from(["0", "-1", "1.5", "x", "99999999999", "", "1e3"])


def outs(kind: str) -> st.SearchStrategy[str]:
    """--out values: placeholders resolved against the fixture's files (``@name``)."""
    base = ["@file", "@under_file", "@dir", "/proc/mbimpact-nope/x", "", "bad\x00name"]
    return st.sampled_from(base + (["@new/demo.csv"] if kind == "file" else ["@new"]))


@st.composite
def argvs(draw: st.DrawFn) -> list[str]:
    command = draw(st.sampled_from(["demo", "compare", "compare", "compare", "run", "scene", "fit", "figures", "bench",
                                    "junk"]))
    argv: list[str] = [] if command == "junk" else [command]
    opt = draw

    def maybe(*tokens: str | st.SearchStrategy[str]) -> None:
        if opt(st.booleans()):
            argv.extend(t if isinstance(t, str) else opt(t) for t in tokens)

    if command == "demo":
        maybe("--e", numbers(["0.5", "1", "0"]))
        maybe("--out", outs("file"))
    elif command == "compare":
        if opt(st.booleans()):
            maybe("--robot", st.sampled_from(["ur5", "panda", "double_pendulum", "romeo", "nope", "", "UR5"]))
        else:
            maybe("--urdf", st.sampled_from(["@pendulum.urdf", "@broken.urdf", "@file", "@dir", "/no/such.urdf"]))
            maybe("--floating")
        maybe("--frame", st.sampled_from(["tool0", "tip", "nope", "universe", "", "panda_hand"]))
        maybe("--q", st.sampled_from(["0.3", "1,2", "a,0,0,0,0,0", "nan,0,0,0,0,0", "0,-1.2,1.6,-1.97,-1.57,0",
                                      "0,0,0,0,0,0,0,0,0", "", ",", "1e308,0,0,0,0,0"]))
        maybe("--speed", numbers(["1", "0.1", "1e100"]))
        maybe("--alpha", numbers(["0.3", "1.5"]))
        maybe("--planar")
        maybe("--e", numbers(["0.8", "2"]))
        maybe("--mu", numbers(["0.3", "-0.1", "50"]))
        maybe("--restitution", st.sampled_from(["newton", "poisson", "energetic", "stronge"]))
        maybe("--facet", st.sampled_from(["coulomb", "compliant", "hunt-crossley", "newton", ""]))
        maybe("--stiffness-ratio", numbers(["0.8", "2"]))
        maybe("--max-beta", numbers(["85", "89.999", "90", "0"]))
        argv += ["--steps", opt(counts(["1", "2", "3"]))]  # always a few: the default 35 is long for a fuzz
        maybe("--out", outs("dir"))
    elif command == "run":
        argv.append(opt(st.sampled_from(["@tiny.toml", "@typo.toml", "@nan.toml", "@notoml.toml", "@file", "@dir",
                                         "ball_drop", "double_pendulum_wall", "nope", "", "@table.csv"])))
        maybe("--no-progress")
        maybe("--out", outs("dir"))
    elif command == "scene":
        maybe(st.sampled_from(["@tiny.toml", "@typo.toml", "@nan.toml", "@notoml.toml", "ball_drop", "box_landing",
                               "nope", "@dir", "--help"]))
    elif command == "fit":
        argv.append(opt(st.sampled_from(["kharaz2001", "@table.csv", "@bad.csv", "@empty.csv", "@file", "@dir", "nope",
                                         "@tiny.toml"])))
        # a law always: the default families take a minute
        argv += ["--law", opt(st.sampled_from(["newton", "foo", "", "newton,foo", ","]))]
        maybe("--body", st.sampled_from(["point", "sphere radius=0.01 mass=0.1", "sphere radius=-1", "cube", ""]))
        maybe("--speed", numbers(["1.0", "3"]))
        maybe("--starts", counts(["1", "2"]))
        maybe("--seed", st.sampled_from(["0", "7", "-1", "x", "1.5", ""]))
        maybe("--out", outs("dir"))
    elif command == "figures":
        argv += ["--out", opt(st.sampled_from(["@file", "@under_file", "/proc/mbimpact-nope/x", "bad\x00name"]))]
    elif command == "bench":
        argv += opt(st.sampled_from([["--part", "nope"], ["--bogus"], ["--quick", "--part", ""], ["--out", "@file"]]))
    else:
        argv += opt(st.lists(st.sampled_from(["--version", "--help", "-h", "frobnicate", "--", "-", "--e", "0.5",
                                              "demo", "--out"]) | st.text(max_size=8), max_size=4))
    if opt(st.integers(0, 9)) == 0:  # now and then a stray token or option
        argv.insert(opt(st.integers(0, len(argv))), opt(st.sampled_from(["--bogus", "extra", "-x", "--e=1", "--"])))
    return argv


def resolve(argv: list[str], files: dict[str, str]) -> list[str]:
    out = []
    for token in argv:
        name, _, rest = token[1:].partition("/")
        if token.startswith("@") and name in files:
            token = files[name] + (f"/{rest}" if rest else "")
        out.append(token)
    return out


def run(argv: list[str]) -> tuple[int | str | None, str, str]:
    """main(argv) in-process: its exit status (or argparse's), stdout and stderr."""
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # warnings are printed, not raised, by the console script too
        with time_limit(LIMIT):
            try:
                code: int | str | None = main(argv)
            except SystemExit as exc:  # argparse: --help, --version, usage errors
                code = exc.code
    return code, out.getvalue(), err.getvalue()


def check(argv: list[str]) -> None:
    code, out, err = run(argv)
    assert code in (0, 2, 3, None), (argv, code, err[-500:])
    assert "Traceback" not in err and "Traceback" not in out, (argv, err[-2000:])
    if code not in (0, None):
        assert err.strip(), (argv, code)  # a message saying what was wrong


@settings(max_examples=200, deadline=None)
@given(argvs())
def test_random_command_lines_end_with_a_status_and_a_message(files, argv):
    check(resolve(argv, files))


def test_the_grammar_reaches_success(files):
    """The fuzz also runs valid commands (quickly): they succeed."""
    # (a one-joint pendulum's tip moves along one line only: compare refuses its oblique approaches)
    for argv in (["compare", "--robot", "ur5", "--steps", "2"],
                 ["run", "@tiny.toml", "--no-progress"], ["scene", "@tiny.toml"],
                 ["fit", "@table.csv", "--law", "newton"],
                 ["--version"]):
        code, _, err = run(resolve(argv, files))
        assert code in (0, None), (argv, err)


# ---------------------------------------------------------------- nightly size: pytest -m slow

@pytest.mark.slow
@settings(max_examples=10_000, deadline=None)
@given(argvs())
def test_random_command_lines_end_with_a_status_and_a_message_nightly(files, argv):
    check(resolve(argv, files))


"""Adversarial specs and command lines keep the error contract: exit 2 with exactly one line on stderr, or exit
0/1 for a valid spec; never an exception out of `main`, never an internal error (exit 3), never a hang, memory
bounded; and a spec that `gen` accepts yields Python that imports and C that compiles without a warning.

`tests/fuzz_corpus/` holds one small file per kind of adversarial input (`bench/fuzz.py` finds them at
scale); the big ones are made here. The hypothesis fuzzer at the end mutates the shipped specs' text.
"""

from __future__ import annotations

import contextlib
import re
import resource
import shutil
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from types import FrameType

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mlca_verify.cli import main
from mlca_verify.errors import MlcaError
from mlca_verify.model import Machine
from mlca_verify.spec import load_text
from tests.conftest import ROOT

CORPUS = Path(__file__).resolve().parent / "fuzz_corpus"
CORPUS_FILES = sorted(CORPUS.glob("*.toml"))
SHIPPED_TEXTS = [
    t for p in sorted(ROOT.glob("spec/**/*.toml")) if "[network]" not in (t := p.read_text(encoding="utf-8"))
]

ERROR, VALID, EITHER = "error", "valid", "either"
TIME_LIMIT_S = 60  # per command, in process
MEMORY_LIMIT_MB = 1024  # address space a command may add to the test process
QUERY_TIMEOUT_MS = "2000"

# What each corpus file must give. ERROR: exit 2 and one line. VALID: `check` exits 0 or 1. EITHER: a clean
# rejection (exit 2, one line) or acceptance (0 or 1); a loader may refuse the input or handle it. Files not
# named here are ERROR. Whenever `gen` accepts a file, the generated code must import and compile.
# `gen` does not load the specs named in [[compare]], so a bad one there is an ERROR of `check` only.
# A string `within` is a bound over params (machines with data); "3" is the bound 3.
VALID_FILES = frozenset(
    {
        "valid_toy",
        "compare_with_self",
        "type_within_string",
        # the engine's and the generated code's own names, where they cannot clash, and arithmetic traps: each is
        # checked (with a caveat, an ovf: or div: finding where the code's arithmetic parts from the reals)
        "namespace_input_first",
        "namespace_signal_mode",
        "namespace_variable_respond",
        "namespace_definition_shape0",
        "namespace_definition_prev0",
        "within_K_plus_1",
        "trap_decimal_timer",
        "trap_int_square",
        "trap_int_signal_product",
        "trap_divide_by_zero",
        "trap_boolean_equality",
    }
)
EITHER_FILES = frozenset(
    {
        "property_id_equiv",
        "property_id_fires",
        "property_id_reach",
        "transition_id_equiv",
        "utf8_bom",
        "deep_parens_guard",
        "deep_not_guard",
        "deep_not_parens_invariant",
        "deep_or_chain_guard",
        "deep_and_chain_assume",
        "deep_implies_chain_goal",
        "deep_iff_chain_invariant",
        "deep_mixed_guard",
        "deep_state_set_goal",
        "clash_state_INITIAL",
        "clash_state_FSM_H",
        "clash_state_mro",
        "clash_state_name",
        "clash_state_State",
        "clash_state_Inputs",
        "clash_state_step",
        "clash_state_from_bytes",
        "clash_state_machine_prefix",
        "clash_input_State",
        "clash_input_step",
        "clash_input_header_guard",
        "clash_input_initial_macro",
        "clash_input_EOF",
        "clash_input_fields",
        "clash_machine_State",
        "clash_machine_bool",
        "clash_states_case_and_underscore",
        "clash_property_ids_dash_dot",
        "clash_property_id_state_range",
        "name_300_machine",
        "name_300_state",
        "name_300_input",
        "name_300_property_id",
        "name_300_transition_id",
        "within_1e9",
        "within_int64_max",
        "within_beyond_int64",
        "hostile_input_doc_python_injection",
        "hostile_input_doc_newline",
        "hostile_input_doc_cr",
        "hostile_input_cite_comment_end",
        "hostile_machine_cite_triple_quote",
        "hostile_machine_cite_backslash",
        "hostile_machine_cite_N_escape",
        "hostile_machine_doc_triple_quote",
        "hostile_machine_doc_multiline",
        "hostile_machine_doc_nul",
        "hostile_machine_doc_form_feed",
        "hostile_machine_doc_line_separator",
        "hostile_transition_cite_error_directive",
        "hostile_transition_cite_trigraph",
        "hostile_transition_doc_quotes",
        "hostile_invariant_cite_newline",
        "hostile_liveness_doc_jinja",
    }
)


def expectation(stem: str) -> str:
    return VALID if stem in VALID_FILES else EITHER if stem in EITHER_FILES else ERROR


# --- bounds on a command run in process ----------------------------------------------------------------------


class Hang(BaseException):
    """A command ran past its time limit (a BaseException, so that no `except Exception` swallows it)."""


def _address_space() -> int | None:
    try:
        status = Path("/proc/self/status").read_text()
    except OSError:
        return None
    found = re.search(r"^VmSize:\s+(\d+) kB", status, re.MULTILINE)
    return int(found.group(1)) * 1024 if found else None


@contextlib.contextmanager
def bounded(seconds: float = TIME_LIMIT_S, memory_mb: int = MEMORY_LIMIT_MB) -> Iterator[None]:
    """Raise `Hang` after `seconds`; make allocations beyond `memory_mb` more than now fail with MemoryError."""

    def on_alarm(signum: int, frame: FrameType | None) -> None:
        raise Hang(f"no exit within {seconds:g} s")

    previous = signal.signal(signal.SIGALRM, on_alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    used = _address_space()
    if used is not None:
        limit = used + (memory_mb << 20)
        if hard == resource.RLIM_INFINITY or limit < hard:
            resource.setrlimit(resource.RLIMIT_AS, (limit, hard))
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


def run_cli(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    """`main(argv)` in process: its exit code and stderr; a test failure for anything outside the contract."""
    capsys.readouterr()
    shown = " ".join(a if len(a) < 80 else a[:77] + "..." for a in argv)
    try:
        with bounded():
            code = main(argv)
    except Hang as err:
        pytest.fail(f"mlca-verify {shown}: hang: {err}")
    except MemoryError:
        pytest.fail(f"mlca-verify {shown}: MemoryError (more than {MEMORY_LIMIT_MB} MB)")
    except Exception as err:
        pytest.fail(f"mlca-verify {shown}: raised {type(err).__name__}: {str(err)[:300]}")
    err = capsys.readouterr().err
    if code == 3:
        detail = err
        with contextlib.suppress(Exception, Hang), bounded():
            main([*argv, "--debug"])
            detail = "\n".join(capsys.readouterr().err.strip().splitlines()[-8:])
        pytest.fail(f"mlca-verify {shown}: internal error (exit 3):\n{detail}")
    assert "Traceback" not in err, f"mlca-verify {shown}: traceback on stderr:\n{err[-2000:]}"
    return code, err


def assert_contract(code: int, err: str, expect: str, command: str) -> None:
    lines = err.splitlines()
    if code == 2:
        assert len(lines) == 1, f"{command}: exit 2 with {len(lines)} lines on stderr:\n{err[:2000]}"
    assert code in (0, 1, 2), f"{command}: exit {code}\n{err[-2000:]}"
    if expect == ERROR:
        assert code == 2, f"{command}: bad input accepted (exit {code})"
    if expect == VALID and command == "check":
        assert code in (0, 1), f"{command}: valid spec refused: {err.strip()}"


IMPORT_SNIPPET = """\
import importlib.util, sys
spec = importlib.util.spec_from_file_location("fuzzed_fsm", sys.argv[1])
module = importlib.util.module_from_spec(spec)
sys.modules[spec.name] = module
spec.loader.exec_module(module)
inputs = module.Inputs(**{f: False for f in module.Inputs.__dataclass_fields__})
module.step(module.Context(), inputs) if hasattr(module, "Context") else module.step(module.INITIAL, inputs)
"""


def assert_generated_code_works(out: Path) -> None:
    """The generated Python imports and steps in a fresh interpreter; the C compiles with -Wall -Wextra -Werror."""
    for py in sorted(out.glob("python/*.py")):
        ran = subprocess.run(
            [sys.executable, "-I", "-c", IMPORT_SNIPPET, str(py)],
            check=False,
            capture_output=True,
            text=True,
            timeout=60,
        )
        injected = " (code from the spec ran at import)" if ran.returncode == 97 else ""
        assert ran.returncode == 0, f"generated {py.name} fails to import{injected}:\n{ran.stderr[-1500:]}"
    gcc = shutil.which("gcc")
    if gcc is None:
        return
    for c in sorted(out.glob("c/*.c")):
        ran = subprocess.run(
            [gcc, "-std=c99", "-Wall", "-Wextra", "-Werror", "-c", c.name, "-o", "/dev/null"],
            cwd=c.parent,
            check=False,
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert ran.returncode == 0, f"generated {c.name} does not compile:\n{ran.stderr[-1500:]}"


def check_and_gen(
    spec: str, expect: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], gen_expect: str | None = None
) -> None:
    reports = tmp_path / "reports"
    reports.mkdir()
    check = ["check", spec, "--timeout-ms", QUERY_TIMEOUT_MS, "--quiet"]
    check += ["--json", str(reports / "c.json"), "--junit", str(reports / "c.xml"), "--sarif", str(reports / "c.sarif")]
    code, err = run_cli(check, capsys)
    assert_contract(code, err, expect, "check")
    out = tmp_path / "generated"
    code, err = run_cli(["gen", spec, "--out", str(out)], capsys)
    assert_contract(code, err, gen_expect or (ERROR if expect == ERROR else EITHER), "gen")
    if code == 0:
        assert_generated_code_works(out)


# --- (a) the corpus, and the inputs too big to commit ----------------------------------------------------------


def test_every_corpus_file_has_a_known_expectation() -> None:
    stems = {p.stem for p in CORPUS_FILES}
    assert len(stems) >= 100
    assert not (VALID_FILES | EITHER_FILES) - stems, sorted((VALID_FILES | EITHER_FILES) - stems)
    assert all(p.stat().st_size <= 8192 for p in CORPUS_FILES)


@pytest.mark.parametrize("path", CORPUS_FILES, ids=[p.stem for p in CORPUS_FILES])
def test_corpus_file(path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # run from the corpus folder's path so that [[compare]] paths resolve beside the file, as in use
    gen_expect = EITHER if path.stem.startswith("compare_") else None
    check_and_gen(str(path), expectation(path.stem), tmp_path, capsys, gen_expect)


@pytest.mark.parametrize("path", CORPUS_FILES, ids=[p.stem for p in CORPUS_FILES])
def test_corpus_file_loads_or_fails_in_one_line(path: Path) -> None:
    # the loader itself, not only the CLI (which prints the first line of a message): one line, at the file
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        pytest.skip("not UTF-8: only the file reader sees it")
    load_or_own_error(text)


TOY = (CORPUS / "valid_toy.toml").read_text(encoding="utf-8")


def _many_transitions() -> bytes:
    extra = "".join(
        f'\n[[transition]]\nid = "bulk{k}"\nfrom = "A"\nto = "{"AB"[k % 2]}"\nwhen = "x and not y"\ncite = "b{k}"\n'
        for k in range(2000)
    )
    return (TOY + extra).encode()


def _with_huge_doc() -> bytes:
    return TOY.replace('doc = "a toy machine"', 'doc = "' + "d" * (1 << 20) + '"', 1).encode()


def _with_huge_state_name() -> bytes:
    name = "B" + "b" * (1 << 20)
    return TOY.replace('"B"', f'"{name}"').replace("state == B", f"state == {name}").encode()


def _deep_guard(prefix: str, suffix: str, depth: int) -> bytes:
    return TOY.replace('when = "y"', f'when = "{prefix * depth}y{suffix * depth}"', 1).encode()


def _chain(length: int) -> bytes:
    """A machine whose guard reads a chain of definitions, each reading the next, `length + 1` long."""
    text = (CORPUS / "namespace_input_first.toml").read_text(encoding="utf-8")
    chain = "\n".join(f'c{k} = {{ expr = "c{k + 1} + 1", doc = "d" }}' for k in range(length))
    chain += f'\nc{length} = {{ expr = "n", doc = "d" }}\n'
    return (
        text.replace("[definitions]\n", "[definitions]\n" + chain)
        .replace("first and n > 2", "first and c0 > 70")
        .encode()
    )


BIG_CASES: dict[str, tuple[str, Callable[[], bytes]]] = {
    "transitions_2000_from_one_state": (EITHER, _many_transitions),
    "huge_doc_1mb": (EITHER, _with_huge_doc),
    "huge_state_name_1mb": (EITHER, _with_huge_state_name),
    "deep_parens_100000": (EITHER, lambda: _deep_guard("(", ")", 100_000)),
    "deep_not_100000": (EITHER, lambda: _deep_guard("not ", "", 100_000)),
    "or_chain_100000": (EITHER, lambda: _deep_guard("y or ", "", 100_000)),
    "deep_toml_array_100000": (ERROR, lambda: TOY.replace('["A", "B"]', "[" * 100_000 + "]" * 100_000, 1).encode()),
    "zero_bytes_64mb": (ERROR, lambda: bytes(64 << 20)),
    "comment_16mb": (EITHER, lambda: TOY.encode() + b"#" + b"c" * (16 << 20) + b"\n"),
    "chain_300_definitions": (ERROR, lambda: _chain(300)),
    "chain_64_definitions": (VALID, lambda: _chain(63)),
    "newlines_16mb": (EITHER, lambda: TOY.encode() + b"\n" * (16 << 20)),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", list(BIG_CASES))
def test_big_input(name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    expect, make = BIG_CASES[name]
    spec = tmp_path / f"{name}.toml"
    spec.write_bytes(make())
    check_and_gen(str(spec), expect, tmp_path, capsys)


@pytest.mark.parametrize("spec", ["/dev/zero", "/dev/null", ".", "no/such/spec.toml", "/proc/self/mem"])
def test_spec_argument_that_is_not_a_spec_file(spec: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    check_and_gen(spec, ERROR, tmp_path, capsys)


VALID_SPEC = str(CORPUS / "valid_toy.toml")
# (name, argv with {spec} and {tmp}, expectation)
COMMAND_LINES = [
    ("timeout-negative", ["check", "{spec}", "--timeout-ms", "-1"], EITHER),
    ("timeout-zero", ["check", "{spec}", "--timeout-ms", "0"], EITHER),
    ("timeout-beyond-int64", ["check", "{spec}", "--timeout-ms", "99999999999999999999"], EITHER),
    ("timeout-not-a-number", ["check", "{spec}", "--timeout-ms", "ten"], ERROR),
    ("only-empty", ["check", "{spec}", "--only", ""], EITHER),
    ("only-separators", ["check", "{spec}", "--only", ",,\n,determinism"], EITHER),
    ("only-unknown", ["check", "{spec}", "--only", "nope"], ERROR),
    ("json-is-a-directory", ["check", "{spec}", "--json", "{tmp}"], ERROR),
    ("json-dot", ["check", "{spec}", "--json", "."], ERROR),
    ("json-in-missing-folder", ["check", "{spec}", "--json", "{tmp}/no/such/c.json"], ERROR),
    ("json-name-too-long", ["check", "{spec}", "--json", "{tmp}/" + "j" * 300 + ".json"], ERROR),
    ("sarif-under-a-file", ["check", "{spec}", "--sarif", "{spec}/x.sarif"], ERROR),
    ("emit-tests-under-a-file", ["check", "{spec}", "--emit-tests", "{spec}/tests"], EITHER),
    ("gen-out-is-a-file", ["gen", "{spec}", "--out", "{tmp}/file"], ERROR),
    ("gen-out-under-a-file", ["gen", "{spec}", "--out", "{tmp}/file/x"], ERROR),
    ("gen-out-name-too-long", ["gen", "{spec}", "--out", "{tmp}/" + "o" * 300], ERROR),
    ("gen-check-missing-folder", ["gen", "{spec}", "--check", "--out", "{tmp}/nowhere"], EITHER),
    ("gen-spec-is-a-directory", ["gen", "{tmp}", "--out", "{tmp}/out"], ERROR),
    ("diff-with-dev-zero", ["diff", "{spec}", "/dev/zero"], ERROR),
    ("diff-with-missing", ["diff", "{spec}", "{tmp}/missing.toml"], ERROR),
    ("diagram-out-is-a-directory", ["diagram", "{spec}", "--out", "{tmp}"], ERROR),
    ("diagram-bad-format", ["diagram", "{spec}", "--format", "png"], ERROR),
    ("no-command", [], ERROR),
    ("unknown-option", ["check", "{spec}", "--frobnicate"], ERROR),
]


@pytest.mark.parametrize(("name", "argv", "expect"), COMMAND_LINES, ids=[c[0] for c in COMMAND_LINES])
def test_command_line_edge(
    name: str, argv: list[str], expect: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "file").write_text("not a folder\n")
    spec = tmp_path / "spec.toml"
    shutil.copy(VALID_SPEC, spec)
    filled = [a.replace("{spec}", str(spec)).replace("{tmp}", str(tmp_path)) for a in argv]
    code, err = run_cli(filled, capsys)
    assert_contract(code, err, expect, name)


# --- (b) a hypothesis fuzzer over the loader -------------------------------------------------------------------

HOSTILE_NAMES = [
    "INITIAL", "FSM_H", "mro", "State", "Inputs", "step", "name", "value", "bool", "EOF", "main", "x" * 300,
    "A\\n", "A\\r", "A\\u0000", "A\\u001b", " A", "É", "", "a-b", "a__b", "equiv", "fires", "determinism",
]  # fmt: skip
HOSTILE_TEXTS = ['\\"\\"\\"', "\\\\", "*/", "/*", "\\n#error x\\n", "\\r", "\\u0000", "'''", "{{ x }}", "\\\\N{x}"]
SNIPPETS = [
    "(" * 1000,
    ")" * 1000,
    "not " * 1000,
    " or x" * 1000,
    " -> x" * 1000,
    " <-> x" * 1000,
    "[" * 1000,
    "]" * 1000,
    "{a=" * 300,
    '"""',
    "'''",
    "\\",
    "\n[[transition]]\n",
    "\n[machine]\n",
    "\n[[liveness]]\nid = 'l'\nassume = 'true'\ngoal = 'true'\ncite = 'c'\nwithin = 1000000000\n",
    "9223372036854775808",
    "-9223372036854775809",
    "1e400",
    "nan",
    "1979-05-27T07:32:00Z",
    "\x00",
    "\r",
    "\u2028",
    "\ufeff",
    "\x1b",
]
ALPHABET = "\"'=[]{}(),.#\\\n\r\t\x00\x7f *-<>!:;x1é\u2028"
QUOTED = re.compile(r'"(?:[^"\\\n]|\\.)*"')


@st.composite
def mutated_specs(draw: st.DrawFn) -> str:
    text = draw(st.sampled_from(SHIPPED_TEXTS))
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["delete", "dup", "swap", "flip", "insert", "value", "rename"]))
        lines = text.splitlines(keepends=True) or [""]
        k = draw(st.integers(0, len(lines) - 1))
        if op == "delete":
            del lines[k]
        elif op == "dup":
            lines.insert(k, lines[k])
        elif op == "swap":
            j = draw(st.integers(0, len(lines) - 1))
            lines[k], lines[j] = lines[j], lines[k]
        text = "".join(lines)
        at = draw(st.integers(0, max(0, len(text) - 1)))
        if op == "flip" and text:
            text = text[:at] + draw(st.sampled_from(ALPHABET)) + text[at + 1 :]
        elif op == "insert":
            text = text[:at] + draw(st.sampled_from(SNIPPETS)) + text[at:]
        elif op == "value":
            values = list(QUOTED.finditer(text))
            if values:
                m = values[draw(st.integers(0, len(values) - 1))]
                new = draw(
                    st.one_of(
                        st.sampled_from(HOSTILE_NAMES + HOSTILE_TEXTS).map(lambda s: f'"{s}"'),
                        st.sampled_from(SNIPPETS[:6]).map(lambda s: f'"x{s}"'),
                        st.sampled_from(["1", "true", "[]", "{}", "1.5", '["a", 1]', "[[[]]]", "0"]),
                    )
                )
                text = text[: m.start()] + new + text[m.end() :]
        elif op == "rename":
            names = re.findall(r'"([A-Z][A-Z_]*)"', text)
            if names:
                old = draw(st.sampled_from(sorted(set(names))))
                new = draw(st.sampled_from(HOSTILE_NAMES))
                text = re.sub(rf"\b{re.escape(old)}\b", new.replace("\\", "\\\\"), text)
    return text


def load_or_own_error(text: str) -> None:
    """The loader returns a machine or raises the project's error, whose message is one line at the file."""
    try:
        with bounded(seconds=30):
            machine = load_text(text, "fuzz.toml")
    except MlcaError as err:
        message = str(err)
        assert "\n" not in message and "\r" not in message, repr(message[:300])
        assert message.startswith("fuzz.toml:"), message[:300]
    else:
        assert isinstance(machine, Machine)


QUICK = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
LONG = settings(
    max_examples=5000, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large]
)


@QUICK
@given(mutated_specs())
def test_loader_on_mutated_specs(text: str) -> None:
    load_or_own_error(text)


@pytest.mark.slow
@LONG
@given(mutated_specs())
def test_loader_on_mutated_specs_long(text: str) -> None:
    load_or_own_error(text)

"""Spec text is untrusted: hostile text in every text field and in the spec's path reaches the generated code,
the emitted tests and the CI formats only as comments and strings.

Each case is compared with the same spec whose texts are all plain: the generated Python must parse to the same
syntax tree once string constants are blanked, the generated C must compile under -Werror and preprocess to the
same tokens (comments are gone after preprocessing; the code holds no string literal), the emitted tests
likewise, and JUnit, SARIF and SCXML must parse.
"""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path
from xml.etree import ElementTree as ET

from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from mlca_verify import ci_formats, diagram
from mlca_verify.codegen import generate, write
from mlca_verify.logic import check_all
from mlca_verify.regression_tests import emit
from mlca_verify.spec import load_spec

FIELDS = ("machine_cite", "machine_doc", "input_doc", "input_cite", "t_cite", "t_doc", "inv_cite", "inv_doc")
HAZARDS = ["*/", "/*", '"""', "'''", "\n", "\r", "\r\n", "\\", "??/", "--", "<!--", "]]>", "<script>", "&", "#",
           "\u2028", "\x00", "\x1b[2J", "\t", "é", "\U0001f600", "%s%n", "{{", "}}", "{%", "\\x41", "\\N{", "'"]  # fmt: skip

hostile = st.lists(st.one_of(st.sampled_from(HAZARDS), st.text(max_size=6)), max_size=8).map("".join)
# a folder name: no '/', no NUL, no '.' or '..' alone, at most 200 bytes
folder = hostile.map(lambda t: t.replace("/", "_").replace("\x00", "_").encode()[:200].decode(errors="ignore"))
folder = folder.filter(lambda t: t not in ("", ".", ".."))


def toml_str(text: str) -> str:
    """A TOML basic string holding `text` exactly."""
    out = []
    for char in text:
        if char in '"\\':
            out.append("\\" + char)
        elif ord(char) < 0x20 or ord(char) == 0x7F:
            out.append(f"\\u{ord(char):04x}")
        else:
            out.append(char)
    return '"' + "".join(out) + '"'


def spec_text(texts: dict[str, str]) -> str:
    q = {k: toml_str(v) for k, v in texts.items()}
    return f"""[machine]
name = "Hostile"
initial = "A"
states = ["A", "B"]
cite = {q["machine_cite"]}
doc = {q["machine_doc"]}

[inputs]
a = {{ doc = {q["input_doc"]}, cite = {q["input_cite"]} }}
b = {{ doc = "b", cite = "b" }}

[[transition]]
id = "go"
from = "A"
to = "B"
when = "a and not b"
cite = {q["t_cite"]}
doc = {q["t_doc"]}

[[transition]]
id = "back"
from = "*"
to = "A"
when = "b"
cite = "back"

[[invariant]]
id = "never-B"
expr = "state == A"
expect = "violated"
cite = {q["inv_cite"]}
doc = {q["inv_doc"]}
"""


def _blank_strings(tree: ast.AST) -> str:
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            node.value = ""
    return ast.dump(tree)


def _c_tokens(source_dir: Path, name: str) -> str:
    flags = ["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", f"-I{source_dir}"]
    built = subprocess.run(
        [*flags, "-c", "-o", "/dev/null", str(source_dir / name)], capture_output=True, text=True, check=False
    )
    assert built.returncode == 0, built.stderr
    pre = subprocess.run([*flags, "-E", "-P", str(source_dir / name)], capture_output=True, text=True, check=True)
    return " ".join(pre.stdout.split())


def produce(root: Path, texts: dict[str, str], folder_name: str) -> dict[str, str]:
    """Generate, check and emit for one spec; return a summary of the code: parsed Python, C tokens."""
    spec_dir = root / folder_name
    spec_dir.mkdir(parents=True)
    spec_file = spec_dir / "hostile.toml"
    spec_file.write_text(spec_text(texts), encoding="utf-8")
    loaded = load_spec(spec_file)
    out = root / "generated"
    write(generate(loaded, out), out)
    results = check_all(loaded.machine)
    emitted = root / "emitted"
    emit(loaded, results, out, emitted)
    checked = [(str(spec_file), loaded.machine, results)]
    ET.fromstring(ci_formats.junit_xml(checked).split("\n", 1)[1])
    json.loads(json.dumps(ci_formats.sarif(checked)))
    ET.fromstring(diagram.render(loaded.machine, "scxml").split("\n", 1)[1])
    summary = {p.name: _blank_strings(ast.parse(p.read_text("utf-8"))) for p in [*out.glob("python/*.py")]}
    summary |= {p.name: _blank_strings(ast.parse(p.read_text("utf-8"))) for p in emitted.glob("*.py")}
    summary["c"] = _c_tokens(out / "c", "hostile_fsm.c")
    return summary


PLAIN = dict.fromkeys(FIELDS, "plain")


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(texts=st.fixed_dictionaries(dict.fromkeys(FIELDS, hostile)), folder_name=folder)
@example(texts={**PLAIN, "input_doc": "x\n    __import__('os').system('touch PWNED')\n    #"}, folder_name="f")
@example(texts=PLAIN, folder_name='x";__import__("os").system("touch P");"')
@example(texts=PLAIN, folder_name="*/ int injected; /*")
@example(texts={**PLAIN, "machine_doc": 'end"""\nimport os\n"""'}, folder_name="d")
def test_hostile_text_stays_in_comments_and_strings(
    tmp_path_factory: object, texts: dict[str, str], folder_name: str
) -> None:
    factory = tmp_path_factory
    assert hasattr(factory, "mktemp")
    plain = produce(factory.mktemp("plain"), PLAIN, "plain")  # type: ignore[attr-defined]
    got = produce(factory.mktemp("hostile"), texts, folder_name)  # type: ignore[attr-defined]
    assert got == plain


def test_importing_generated_python_from_a_hostile_spec_has_no_side_effect(tmp_path: Path) -> None:
    texts = {
        **PLAIN,
        "input_doc": "x\n    __import__('os').system('touch PWNED')\n    #",
        "machine_doc": '"""\nopen("PWNED", "w")',
    }
    produce(tmp_path, texts, 'x";__import__("os").system("touch PWNED");"')
    module = tmp_path / "generated" / "python" / "hostile_fsm.py"
    ran = subprocess.run(
        [sys.executable, "-c", f"import runpy; runpy.run_path({str(module)!r})"],
        cwd=tmp_path,
        capture_output=True,
        check=False,
    )
    assert ran.returncode == 0, ran.stderr
    assert not list(tmp_path.rglob("PWNED"))

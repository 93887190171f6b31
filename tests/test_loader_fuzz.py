"""Fuzz the loader: random bytes and mutated valid specs either load or raise the project's own error."""

from __future__ import annotations

import tempfile
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mlca_verify.errors import MlcaError
from mlca_verify.spec import load_spec, load_text

SHIPPED = sorted(Path(__file__).parent.parent.glob("spec/**/*.toml"))
TEXTS = [t for p in SHIPPED if "[network]" not in (t := p.read_text(encoding="utf-8"))]  # the machine specs
FUZZ = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _load_or_own_error(text: str) -> None:
    try:
        load_text(text, "fuzz.toml")
    except MlcaError as err:
        message = str(err)
        assert message.startswith("fuzz.toml:") and "\n" not in message, message


@FUZZ
@given(st.binary(max_size=400))
def test_random_bytes(data: bytes) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "fuzz.toml"
        path.write_bytes(data)
        try:
            load_spec(path)
        except MlcaError as err:
            assert "\n" not in str(err)


@FUZZ
@given(st.sampled_from(TEXTS), st.data())
def test_mutated_specs(text: str, data: st.DataObject) -> None:
    for _ in range(data.draw(st.integers(1, 4))):
        kind = data.draw(st.sampled_from(["delete", "insert", "replace", "dupline", "dropline"]))
        at = data.draw(st.integers(0, max(0, len(text) - 1)))
        if kind == "delete":
            text = text[:at] + text[at + data.draw(st.integers(1, 20)) :]
        elif kind == "insert":
            text = text[:at] + data.draw(st.text(max_size=12)) + text[at:]
        elif kind == "replace":
            token = data.draw(
                st.sampled_from(['"', "=", "[", "]", "{", "}", "not", "and", "(", "state", "*", "1", "\n"])
            )
            text = text[:at] + token + text[at + 1 :]
        else:
            lines = text.splitlines(keepends=True)
            k = data.draw(st.integers(0, len(lines) - 1))
            lines[k : k + 1] = [lines[k], lines[k]] if kind == "dupline" else []
            text = "".join(lines)
    _load_or_own_error(text)


def test_fuzz_corpus_is_the_shipped_specs() -> None:
    assert len(SHIPPED) >= 4
    for text in TEXTS:
        load_text(text, "fuzz.toml", None)

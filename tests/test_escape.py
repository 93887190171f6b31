"""The escaping filters: the identity on plain text (so ordinary specs generate the same bytes), and nothing
that could end the comment or string they write into."""

from __future__ import annotations

import ast
import re
import string

from hypothesis import given
from hypothesis import strategies as st

from mlca_verify import escape

PLAIN = "Alg. 1, l.9-10 (Assert 3): 'the AV transitions to the Moving Left' [Fig. 1]"
FILTERS = [escape.c_comment, escape.py_comment, escape.py_docstring, escape.xml_text, escape.terminal]


def test_plain_text_is_left_as_it_is() -> None:
    for f in FILTERS:
        assert f(PLAIN) == PLAIN, f.__name__
    assert escape.c_string("plain text") == "plain text"
    assert escape.py_string("plain") == '"plain"'


@given(st.text())
def test_a_c_comment_cannot_be_closed_spliced_or_split(text: str) -> None:
    out = escape.c_comment(text)
    assert "*/" not in out and "/*" not in out and "??" not in out
    assert set(out) <= set(string.printable) - set("\n\r\t\x0b\x0c")


@given(st.text())
def test_a_python_string_literal_has_the_text_as_its_value(text: str) -> None:
    literal = escape.py_string(text)
    assert ast.literal_eval(literal) == text
    assert "\n" not in literal and literal.isascii()


@given(st.text())
def test_a_docstring_body_cannot_end_the_docstring(text: str) -> None:
    body = escape.py_docstring(text)
    assert ast.literal_eval(f'"""{body}"""') == text.replace("\r\n", "\n")


@given(st.text())
def test_a_c_string_body_escapes_quotes_backslashes_trigraphs_and_bytes(text: str) -> None:
    body = escape.c_string(text)
    assert body.isascii() and body.isprintable()
    assert not re.search(r'(?<!\\)(\\\\)*"', body)  # every quote is escaped
    assert "??" not in body


@given(st.text())
def test_xml_comments_hold_no_double_hyphen(text: str) -> None:
    out = escape.xml_comment(text)
    assert "--" not in out and not out.endswith("-")


@given(st.text())
def test_terminal_text_holds_no_control_character(text: str) -> None:
    assert all(c.isprintable() for c in escape.terminal(text))

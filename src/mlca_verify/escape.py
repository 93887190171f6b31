"""Escaping filters: spec text (names, docs, cites, paths) made harmless for the place it lands.

Every filter is the identity on plain printable ASCII that holds none of its context's special sequences, so
ordinary specs generate the same bytes as ever; anything else (newlines, control and non-ASCII characters,
comment terminators, quotes, backslashes, trigraphs) is written as a visible escape that cannot end the
comment or string it sits in.
"""

from __future__ import annotations

import re

_NAMED = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}
_UNSAFE = re.compile(r"[^\x20-\x7e]")
# XML 1.0 allows tab, newline, carriage return and everything from U+0020 except surrogates, U+FFFE and U+FFFF.
_XML_INVALID = re.compile("[^\t\n\r\x20-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


def c_form(name: str) -> str:
    """A name as it appears inside generated C identifiers and file names (property ids may hold '-' and '.')."""
    return re.sub(r"[-.]", "_", name)


def _code(char: str) -> str:
    """A visible escape for one character, as Python writes it in a string literal."""
    if char in _NAMED:
        return _NAMED[char]
    point = ord(char)
    if point < 0x100:
        return f"\\x{point:02x}"
    return f"\\u{point:04x}" if point < 0x10000 else f"\\U{point:08x}"


def printable(text: str) -> str:
    """One line of printable ASCII: every other character (newlines included) as its visible escape."""
    return _UNSAFE.sub(lambda m: _code(m.group()), text)


def c_comment(text: str) -> str:
    """Text for one line inside a C block comment: it cannot close the comment, open another one, splice the
    next line (a trailing backslash) or form a trigraph."""
    text = printable(text.replace("\\", "\\\\"))
    text = text.replace("*/", "* /").replace("/*", "/ *")
    return re.sub(r"\?(?=\?)", r"?\\", text)


def c_string(text: str) -> str:
    """The body of a C string literal (without its quotes): \\n, \\r, \\t, and octal escapes for every other byte
    outside printable ASCII, so that no escape can swallow the characters after it."""
    out = []
    for byte in text.encode("utf-8"):
        char = chr(byte)
        if char in '"\\?':
            out.append("\\" + char)
        elif char in _NAMED:
            out.append(_NAMED[char])
        elif 0x20 <= byte < 0x7F:
            out.append(char)
        else:
            out.append(f"\\{byte:03o}")
    return "".join(out)


def py_comment(text: str) -> str:
    """Text for one line of a Python `#` comment."""
    return printable(text)


def _py_line(text: str) -> str:
    """One line of a double-quoted Python string's body: backslashes and quotes escaped, the rest printable."""
    return printable(text.replace("\\", "\\\\").replace('"', '\\"'))


def py_string(text: str) -> str:
    """A double-quoted Python string literal whose value is `text`, in printable ASCII."""
    return '"' + _py_line(text) + '"'


def py_docstring(text: str) -> str:
    """Text inside a triple-quoted Python docstring: lines kept, backslashes and quotes escaped, every other
    control or non-ASCII character as its escape (so the docstring's value is the text itself)."""
    lines = text.replace("\r\n", "\n").split("\n")
    return "\n".join(_py_line(line) for line in lines)


def xml_text(text: str) -> str:
    """Text that XML 1.0 can hold (the serializer escapes markup): invalid characters as visible escapes."""
    return _XML_INVALID.sub(lambda m: _code(m.group()), text)


def xml_markup(text: str) -> str:
    """Text between XML tags: `&`, `<` and `>` as references (the text itself must be XML 1.0: see xml_text)."""
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def xml_attribute(text: str) -> str:
    """`text` as a quoted XML attribute value: markup and line breaks as references; in single quotes when it holds
    a double quote and no single one (a JSON string then reads as itself), else in double quotes."""
    marked = xml_markup(text).replace("\n", "&#10;").replace("\r", "&#13;").replace("\t", "&#9;")
    if '"' in text and "'" not in text:
        return f"'{marked}'"
    return '"' + marked.replace('"', "&quot;") + '"'


def xml_comment(text: str) -> str:
    """Text for one line inside an XML comment: no `--`, no trailing `-`, no invalid character."""
    text = printable(text)
    while "--" in text:
        text = text.replace("--", "- -")
    return text + " " if text.endswith("-") else text


def one_line(text: str) -> str:
    """Text for a line of a text format with no escapes of its own (a terminal, Markdown, Mermaid comment)."""
    return printable(text)


def terminal(text: str) -> str:
    """Text for a terminal line: printable characters kept (non-ASCII letters included), control and format
    characters (escape sequences, newlines) as visible escapes."""
    return "".join(char if char.isprintable() else _code(char) for char in text)

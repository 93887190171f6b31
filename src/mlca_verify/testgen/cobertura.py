"""The suite's coverage of the generated C as Cobertura XML, which CI reads, from llvm-cov's LCOV export
(coverage.py writes the Python's)."""

from __future__ import annotations

from xml.etree import ElementTree as ET

from mlca_verify.escape import xml_text
from mlca_verify.version import __version__


def cobertura_from_lcov(lcov: str, source: str, timestamp: int = 0) -> str:
    """A Cobertura report of one source file from its LCOV record (DA line hits, BRDA branch hits)."""
    hits: dict[int, int] = {}
    branches: dict[int, list[bool]] = {}
    for line in lcov.splitlines():
        if line.startswith("DA:"):
            fields = line[3:].split(",")
            hits[int(fields[0])] = int(fields[1])
        elif line.startswith("BRDA:"):
            fields = line[5:].split(",")
            branches.setdefault(int(fields[0]), []).append(fields[3] not in ("-", "0"))
    lines_hit = sum(1 for c in hits.values() if c > 0)
    all_branches = [b for bs in branches.values() for b in bs]
    line_rate = lines_hit / len(hits) if hits else 1.0
    branch_rate = sum(all_branches) / len(all_branches) if all_branches else 1.0
    root = ET.Element(
        "coverage",
        {
            "line-rate": f"{line_rate:.4f}",
            "branch-rate": f"{branch_rate:.4f}",
            "lines-covered": str(lines_hit),
            "lines-valid": str(len(hits)),
            "branches-covered": str(sum(all_branches)),
            "branches-valid": str(len(all_branches)),
            "complexity": "0",
            "version": __version__,
            "timestamp": str(timestamp),
        },
    )
    package = ET.SubElement(ET.SubElement(root, "packages"), "package", name="generated", complexity="0")
    package.set("line-rate", f"{line_rate:.4f}")
    package.set("branch-rate", f"{branch_rate:.4f}")
    cls = ET.SubElement(ET.SubElement(package, "classes"), "class", name=xml_text(source), filename=xml_text(source))
    cls.set("line-rate", f"{line_rate:.4f}")
    cls.set("branch-rate", f"{branch_rate:.4f}")
    cls.set("complexity", "0")
    ET.SubElement(cls, "methods")
    lines = ET.SubElement(cls, "lines")
    for number in sorted(hits):
        entry = ET.SubElement(lines, "line", number=str(number), hits=str(hits[number]))
        taken = branches.get(number)
        entry.set("branch", "true" if taken else "false")
        if taken:
            entry.set("condition-coverage", f"{100 * sum(taken) // len(taken)}% ({sum(taken)}/{len(taken)})")
    ET.indent(root)
    return '<?xml version="1.0" ?>\n' + ET.tostring(root, encoding="unicode") + "\n"

"""A synthetic machine with many transitions out of one state, which the scaling benchmark and its tests load."""

from __future__ import annotations


def wide_spec(n: int, style: str = "shadowed", semantics: str = "first-match", n_inputs: int = 5) -> str:
    """States A, B, C; `n` transitions out of A. `shadowed`: guards `x and y{k % 5}` (only the first five fire);
    `cubes`: pairwise disjoint cubes over the inputs (every one fires), alternating between B and C."""
    ys = [f"y{i}" for i in range(n_inputs)]
    lines = ["[machine]", 'name = "Wide"', 'initial = "A"', 'states = ["A", "B", "C"]', f'semantics = "{semantics}"']
    lines += ['cite = "test"', "", "[inputs]", 'x = { doc = "x", cite = "test" }']
    lines += [f'{y} = {{ doc = "{y}", cite = "test" }}' for y in ys]
    for k in range(n):
        if style == "shadowed":
            when, to = f"x and y{k % 5}", "B"
        else:
            when = " and ".join(["x", *[y if (k >> i) & 1 else f"not {y}" for i, y in enumerate(ys)]])
            to = "BC"[k % 2]
        lines += ["", "[[transition]]", f'id = "t{k}"', 'from = "A"', f'to = "{to}"', f'when = "{when}"']
        lines += ['cite = "test"']
    for source in ("B", "C"):
        lines += ["", "[[transition]]", f'id = "back_{source}"', f'from = "{source}"', 'to = "A"', 'when = "not x"']
        lines += ['cite = "test"']
    return "\n".join(lines) + "\n"

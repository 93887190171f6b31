"""Requirements-based tests of the generated code, to MC/DC, with their coverage measured."""

DEPTH = 30  # the longest run the test generator searches (`mlca-verify tests --depth`)

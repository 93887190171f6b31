"""The toolkit's version, which the generated files, the reports and `--version` carry."""

__version__ = "0.1.0"

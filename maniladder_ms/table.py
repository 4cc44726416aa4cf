"""Plain-text tables for the command line."""

import sys


def print_table(header, rows, file=None):
    """Left-aligned columns under a dashed rule."""
    file = file or sys.stdout
    widths = [max(len(str(x)) for x in col) for col in zip(header, *rows)]
    for line in (header, tuple("-" * w for w in widths), *rows):
        print("  ".join(str(x).ljust(w) for x, w in zip(line, widths)).rstrip(), file=file)

"""Command-line numbers and names checked where they are parsed: argparse names the flag in the
error and exits with 2 (`argument --epochs: expected an integer >= 1, got '0'`), before any data
is read. Found in review: --epochs 0 and --batch-size 0 were tracebacks, --jobs 0 and --seeds 0
silently did something else, an unknown --models name failed only when its first run started.
Used by `python3 -m imukit.har` and `imukit.datasets.utd_mhad_scenes`.
"""
import argparse
import math

_NAMES = {int: "an integer", float: "a number"}


def number(kind, minimum):
    """An argparse type: a finite `kind` (int or float) of at least `minimum`."""
    expected = f"expected {_NAMES[kind]} >= {minimum:g}"

    def parse(text):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{expected}, got {text!r}") from None
        if not (math.isfinite(value) and value >= minimum):
            raise argparse.ArgumentTypeError(f"{expected}, got {text!r}")
        return value
    return parse


def numbers(kind, minimum):
    """An argparse type: a comma-separated list of number(kind, minimum)."""
    one = number(kind, minimum)

    def parse(text):
        return [one(item.strip()) for item in text.split(",")]
    return parse


def names(known):
    """An argparse type: a comma-separated list of names, each one of `known`."""
    expected = f"expected one of {', '.join(known)}"

    def parse(text):
        items = [item.strip() for item in text.split(",")]
        for i, item in enumerate(items):
            if item not in known:
                raise argparse.ArgumentTypeError(f"{expected}, got {item!r}")
            if item in items[:i]:
                # each run would be trained twice and stored twice under one key (found in review)
                raise argparse.ArgumentTypeError(f"{item!r} listed twice")
        return items
    return parse

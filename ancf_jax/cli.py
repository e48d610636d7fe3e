"""Command-line interface ``ancf-jax``."""

from __future__ import annotations

import argparse
import sys

from ._version import __version__


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="ancf-jax",
        description="Differentiable planar ANCF beams and cables with rigid multibody "
                    "systems (Seo, Jung & Park), on JAX.")
    parser.add_argument("--version", action="version", version=f"ancf-jax {__version__}")
    parser.add_subparsers(dest="command", metavar="COMMAND")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 0
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Command-line interface (typer + rich). Thin: parse, read through ``io``, one library call, write."""

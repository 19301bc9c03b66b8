"""The built-in demonstrations run by ``longprofile demo`` (an edge: each module may use the domains, ``io``
and ``report``; nothing in the library imports this package).

Each module has ``run_demo(outdir: pathlib.Path) -> list[pathlib.Path]`` (the files it wrote).
"""

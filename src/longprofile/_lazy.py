"""PEP 562 lazy package namespaces: a public name is imported from its submodule on first access.

A package ``__init__`` lists which submodule defines each public name and gets ``__getattr__`` / ``__dir__`` from
:func:`lazy_namespace`, so importing the package imports none of its submodules (a CLI command loads only what it
uses) while ``from package import name``, ``__all__`` and ``dir()`` behave as with eager imports.
"""

from __future__ import annotations

import importlib
import sys
from typing import Callable, Iterable, Mapping

__all__ = ["lazy_namespace"]


def lazy_namespace(package: str, exports: Mapping[str, Iterable[str]], public: Iterable[str], *,
                   submodules: Iterable[str] = ()) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` for the package ``package``.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    exports : mapping
        Submodule (relative, e.g. ``"._data"``) -> the public names it defines.
    public : iterable of str
        The package's ``__all__`` (listed by ``dir()`` before anything is loaded).
    submodules : iterable of str, optional
        Subpackages reachable as attributes (``package.apl``), imported on first access.
    """
    where = {name: module for module, names in exports.items() for name in names}
    where.update({name: None for name in submodules})
    public = tuple(public) + tuple(submodules)

    def __getattr__(name: str):
        if name in where and where[name] is None:
            return importlib.import_module(f"{package}.{name}")
        module = where.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module, package), name)
        setattr(sys.modules[package], name, value)  # cached: the next access is a plain attribute
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(public))

    return __getattr__, __dir__

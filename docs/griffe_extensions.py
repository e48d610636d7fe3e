"""Griffe extensions for the API reference (loaded by mkdocs.yml).

* Sphinx roles in docstrings (``:class:`Carry```, ``:func:`~ancf_jax.simulation.simulate```)
  become inline code (``Carry``, ``simulate``), so they read as names, not markup.
* A method without a docstring that overrides a documented one of a base class in the
  package inherits that docstring (the integrators, joints, points and forces document
  their interface once, in the abstract base).
"""

from __future__ import annotations

import re
from typing import Any

import griffe

_ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|data|attr|obj|exc|const):`~?([^`]+)`")


def _code(match: re.Match) -> str:
    target = match.group(1)
    return f"`{target.split('.')[-1] if match.group(0).count('~') else target}`"


class SphinxRoles(griffe.Extension):
    """Replace Sphinx cross-reference roles by inline code."""

    def on_instance(self, *, obj: griffe.Object, **kwargs: Any) -> None:
        if obj.docstring is not None and ":`" in obj.docstring.value:
            obj.docstring.value = _ROLE.sub(_code, obj.docstring.value)


class InheritDocstrings(griffe.Extension):
    """Give undocumented overriding methods the docstring of the base-class method."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        self._walk(pkg)

    def _walk(self, obj: griffe.Object) -> None:
        for member in list(obj.members.values()):
            if member.is_alias:
                continue
            if member.is_class:
                self._inherit(member)
            if member.is_module or member.is_class:
                self._walk(member)

    @staticmethod
    def _inherit(cls: griffe.Class) -> None:
        try:
            bases = cls.mro()
        except Exception:  # unresolved bases (outside the package)
            return
        for name, member in cls.members.items():
            if member.is_alias or not member.is_function or member.docstring is not None:
                continue
            for base in bases:
                found = base.members.get(name)
                if found is not None and not found.is_alias and found.docstring is not None:
                    member.docstring = griffe.Docstring(found.docstring.value, parent=member,
                                                        parser=found.docstring.parser,
                                                        parser_options=found.docstring.parser_options)
                    break

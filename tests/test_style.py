"""The library's module design rule (equinox style): every ``eqx.Module`` is abstract or
final, and no subclass overrides a concrete method or property of its base (a base
states an interface with abstract methods; shared behaviour lives in concrete methods
that nobody replaces). Checked over every class of the package."""

import importlib
import inspect
import pkgutil

import equinox as eqx

import ancf_jax


def _module_classes():
    classes = set()
    for info in pkgutil.walk_packages(ancf_jax.__path__, "ancf_jax."):
        mod = importlib.import_module(info.name)
        for _, cls in inspect.getmembers(mod, inspect.isclass):
            if issubclass(cls, eqx.Module) and cls.__module__.startswith("ancf_jax"):
                classes.add(cls)
    return classes


def _is_abstract_member(value) -> bool:
    return getattr(getattr(value, "fget", value), "__isabstractmethod__", False)


def test_no_concrete_method_is_overridden():
    bad = []
    for cls in _module_classes():
        for attr in cls.__dict__:
            if attr.startswith("__") or attr == "_abc_impl":
                continue
            for base in cls.__mro__[1:]:
                if not base.__module__.startswith("ancf_jax"):
                    continue
                if attr in base.__dict__:
                    if not _is_abstract_member(base.__dict__[attr]):
                        bad.append(f"{cls.__qualname__}.{attr} overrides {base.__qualname__}.{attr}")
                    break
    assert not bad, "; ".join(sorted(bad))


def test_every_module_is_abstract_or_final():
    classes = _module_classes()
    subclassed = {base for cls in classes for base in cls.__mro__[1:] if base in classes}
    not_abstract = sorted(c.__qualname__ for c in subclassed
                          if not (inspect.isabstract(c) and c.__name__.startswith("Abstract")))
    assert not not_abstract, f"subclassed but not abstract: {not_abstract}"
    named_abstract = sorted(c.__qualname__ for c in classes
                            if c.__name__.startswith("Abstract") and not inspect.isabstract(c))
    assert not named_abstract, f"named Abstract* but instantiable: {named_abstract}"

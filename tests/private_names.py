"""Private names used across modules (issue 20), read with ``ast``: a first-party module uses
a private name (``_name`` or ``__name``; not a dunder ``__name__``) that another first-party
module defines. Seen from the source alone:

- imported: ``from m import _name`` (``from pkg import _module`` too);
- through a module: ``import m``, ``import pkg.m as x`` or ``from pkg import m``, then
  ``m._name``; through a class or object imported from another module: ``Cls._name``;
- inherited: a class whose base comes from another module uses or overrides a private member
  of that base (``self._lock`` the base set; a ``def _hook`` the base defines);
- on any other object: ``obj._name`` where this module defines no ``_name`` but another
  first-party module does (``player._emit`` called by the runner). The reader cannot know
  ``obj``'s class, so this one goes by the name alone.

A module's own private names never count, nor those of modules outside the tree
(``os._exit``, a namedtuple's ``_replace``).
"""

from __future__ import annotations

import ast
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from tests.import_graph import relative_base, resolve


def is_private(name: str) -> bool:
    """``_name`` and ``__name`` (mangled) are private; ``__name__`` and ``_`` are not."""
    return name.startswith("_") and not name.endswith("__") and name.strip("_") != ""


@dataclass(frozen=True, order=True)
class PrivateUse:
    file: str  # the using file, relative to the root
    line: int
    module: str  # the using module
    name: str  # the private name, e.g. "_emit"
    owner: str  # where it is defined: a module, a module's class, or several modules
    how: str  # imported | module attribute | class attribute | inherited | attribute

    def __str__(self) -> str:
        return (f"{self.file}:{self.line}: {self.module} uses {self.name} of {self.owner} "
                f"({self.how})")


@dataclass
class Module:
    """What the reader knows of one module."""

    name: str
    file: str
    tree: ast.Module
    bound: dict[str, str] = field(default_factory=dict)  # local name -> dotted first-party path
    defines: set[str] = field(default_factory=set)  # the private names it defines anywhere
    classes: dict[str, ast.ClassDef] = field(default_factory=dict)  # its top-level classes


def _defined(tree: ast.AST) -> set[str]:
    """Every private name a piece of source defines: functions, classes, variables,
    attributes it sets, arguments, import aliases, ``__slots__`` entries."""
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            names.add(node.attr)
        elif isinstance(node, ast.arg):
            names.add(node.arg)
        elif isinstance(node, ast.alias) and node.asname:
            names.add(node.asname)
        elif isinstance(node, ast.Assign) and any(
                isinstance(t, ast.Name) and t.id == "__slots__" for t in node.targets):
            names |= {c.value for c in ast.walk(node.value)
                      if isinstance(c, ast.Constant) and isinstance(c.value, str)}
    return {name for name in names if is_private(name)}


def _members(cls: ast.ClassDef, uses: bool) -> list[tuple[ast.AST, str]]:
    """A class's private members: its methods and class variables, the attributes its methods
    set on ``self`` or ``cls`` (and, with ``uses``, read from them)."""
    found: list[tuple[ast.AST, str]] = []
    for stmt in cls.body:
        if isinstance(stmt, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            found.append((stmt, stmt.name))
        elif isinstance(stmt, (ast.Assign, ast.AnnAssign)):
            targets = stmt.targets if isinstance(stmt, ast.Assign) else [stmt.target]
            found += [(t, t.id) for t in targets if isinstance(t, ast.Name)]
    found += [(node, node.attr) for node in ast.walk(cls) if isinstance(node, ast.Attribute)
              and isinstance(node.value, ast.Name) and node.value.id in ("self", "cls")
              and (uses or isinstance(node.ctx, ast.Store))]
    return [(node, name) for node, name in found if is_private(name)]


def _bindings(module: str, tree: ast.Module, modules: dict[str, Path]) -> dict[str, str]:
    """The local names its imports bind to first-party things: name -> dotted path
    (``import a.b`` binds ``a``; ``from a import b as c`` binds ``c`` to ``a.b``). Scopes are
    not told apart: an import inside a function binds as one at module level."""
    bound: dict[str, str] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                local = alias.asname or alias.name.split(".")[0]
                path = alias.name if alias.asname else local
                if resolve(path, modules) is not None:
                    bound[local] = path
        elif isinstance(node, ast.ImportFrom):
            origin = _origin(node, module, modules)
            if origin and resolve(origin, modules) is not None:
                for alias in node.names:
                    bound[alias.asname or alias.name] = f"{origin}.{alias.name}"
    return bound


def _origin(node: ast.ImportFrom, module: str, modules: dict[str, Path]) -> str:
    """The absolute dotted name a ``from ... import`` reads from."""
    if not node.level:
        return node.module or ""
    base = relative_base(module, node.level, modules)
    return ".".join(p for p in (base, node.module or "") if p)


def _dotted(node: ast.expr) -> str | None:
    """``a.b.c`` for a chain of names and attributes; None for anything else."""
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        head = _dotted(node.value)
        return f"{head}.{node.attr}" if head else None
    return None


@dataclass
class Reader:
    """Reads who uses another module's private names: ``modules`` are those whose private
    names count (the packages'); :meth:`uses` reads any module; ``allowed(user, owner)`` names
    the exceptions (a test reaching into the module it mirrors)."""

    modules: dict[str, Path]  # every first-party module that can own a private name
    root: Path
    allowed: Callable[[str, str], bool] = lambda user, owner: False
    read: dict[str, Module] = field(default_factory=dict)
    definers: dict[str, list[str]] = field(default_factory=dict)  # private name -> modules

    def module(self, name: str, path: Path) -> Module:
        """One module, read once."""
        if name not in self.read:
            tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
            found = Module(name, path.relative_to(self.root).as_posix(), tree,
                           _bindings(name, tree, self._known(name, path)), _defined(tree))
            found.classes = {n.name: n for n in tree.body if isinstance(n, ast.ClassDef)}
            self.read[name] = found
        return self.read[name]

    def _known(self, name: str, path: Path) -> dict[str, Path]:
        """The modules, with ``name`` among them (a user outside them: its relative imports)."""
        return {**self.modules, name: path}

    def owner(self, name: str) -> Module | None:
        """A first-party module that can own private names, read; None if ``name`` is none."""
        return self.module(name, self.modules[name]) if name in self.modules else None

    def uses(self, users: dict[str, Path]) -> list[PrivateUse]:
        """Every use, in the ``users``' modules, of another module's private name (one per
        line and name: the most precise finding)."""
        found: dict[tuple[str, int, str], PrivateUse | None] = {}
        for name, path in users.items():
            user = self.module(name, path)
            for use in self._uses_in(user):
                owner = use.owner.split(":")[0]
                fine = owner == name or self.allowed(name, owner)
                found.setdefault((use.file, use.line, use.name), None if fine else use)
        return sorted(use for use in found.values() if use is not None)

    def _uses_in(self, user: Module) -> Iterator[PrivateUse]:
        """Imported, through a module or class, inherited, then by name (in that order, so
        that the first, most precise finding of a line and name is the one kept)."""
        for node in ast.walk(user.tree):
            if isinstance(node, ast.ImportFrom):
                origin = _origin(node, user.name,
                                 self._known(user.name, self.root / user.file))
                owner = resolve(origin, self.modules) if origin else None
                for alias in node.names:
                    if owner is not None and is_private(alias.name):
                        yield self._use(user, node, alias.name, owner, "imported")
            elif isinstance(node, ast.Attribute) and is_private(node.attr):
                use = self._through_import(user, node)
                if use is not None:
                    yield use
        for cls in ast.walk(user.tree):
            if isinstance(cls, ast.ClassDef):
                yield from self._inherited(user, cls)
        yield from self._by_name(user)

    def _use(self, user: Module, node: ast.AST, name: str, owner: str, how: str) -> PrivateUse:
        return PrivateUse(user.file, getattr(node, "lineno", 0), user.name, name, owner, how)

    def _through_import(self, user: Module, node: ast.Attribute) -> PrivateUse | None:
        """``m._name`` or ``Cls._name`` where ``m`` or ``Cls`` is bound by an import."""
        dotted = _dotted(node.value)
        if dotted is None:
            return None
        head, _, rest = dotted.partition(".")
        if head not in user.bound:
            return None
        path = ".".join(p for p in (user.bound[head], rest) if p)
        owner = resolve(path, self.modules)
        if owner is None:
            return None
        how = "module attribute" if owner == path else "class attribute"
        return self._use(user, node, node.attr, owner, how)

    def _inherited(self, user: Module, cls: ast.ClassDef) -> Iterator[PrivateUse]:
        """Private members of ``cls`` (defined, or used as ``self._x``) that a base class from
        another module defines."""
        inherited = self.inherited_members(user.name, user, cls)
        for node, name in _members(cls, uses=True):
            if name in inherited:
                yield self._use(user, node, name, inherited[name], "inherited")

    def inherited_members(self, user: str, where: Module, cls: ast.ClassDef,
                          depth: int = 0) -> dict[str, str]:
        """The private members of ``cls``'s first-party bases, and of theirs, that a module
        other than ``user`` defines: name -> "module:Class" (``cls`` is in ``where``)."""
        members: dict[str, str] = {}
        for base in cls.bases if depth < 20 else []:  # 20: a cycle of bases (it would raise)
            found = self._base_class(where, base)
            if found is None:
                continue
            owner, base_cls = found
            if owner.name != user:
                for _, name in _members(base_cls, uses=False):
                    members.setdefault(name, f"{owner.name}:{base_cls.name}")
            for name, at in self.inherited_members(user, owner, base_cls, depth + 1).items():
                members.setdefault(name, at)
        return members

    def _base_class(self, where: Module, base: ast.expr,
                    hops: int = 0) -> tuple[Module, ast.ClassDef] | None:
        """The first-party class a base names, with its module (through re-exports)."""
        dotted = _dotted(base)
        if dotted is None or hops > 5:
            return None
        head, _, rest = dotted.partition(".")
        if head in where.classes and not rest:
            return where, where.classes[head]
        if head not in where.bound:
            return None
        path = ".".join(p for p in (where.bound[head], rest) if p)
        module = resolve(path, self.modules)
        found = self.owner(module) if module else None
        if found is None or found.name == path:
            return None
        return self._base_class(found, ast.Name(path[len(found.name) + 1:]), hops + 1)

    def _by_name(self, user: Module) -> Iterator[PrivateUse]:
        """``obj._name``: this module defines no ``_name``; some other first-party one does."""
        if not self.definers:
            for name, path in sorted(self.modules.items()):
                for private in self.module(name, path).defines:
                    self.definers.setdefault(private, []).append(name)
        for node in ast.walk(user.tree):
            if isinstance(node, ast.Attribute) and is_private(node.attr) and \
                    node.attr not in user.defines:
                owners = [m for m in self.definers.get(node.attr, []) if m != user.name]
                if owners and not any(self.allowed(user.name, owner) for owner in owners):
                    yield self._use(user, node, node.attr, " or ".join(owners[:3]), "attribute")

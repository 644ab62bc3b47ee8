"""procgen: natural-looking content grown from simple local rules.

This module is the whole import surface for plugin authors (see ``__all__``).
"""
from __future__ import annotations

__version__ = "0.1.0"

from .domains import Domain, Grid, PointSet, Polylines, TriMesh, register_domain_kind
from .errors import InputError, MissingExtra, PluginError, ProcgenError, RecipeError
from .exchange import Exporter, FieldName, write
from .fields import FieldSpec
from .hookspecs import hookimpl, hookspec
from .params import param
from .plugins import PluginHost, get_plugin_manager
from .recipes import Recipe, check_recipe, load_recipe
from .rules import Rule, RuleBase
from .runner import RunResult, run
from .state import State, StepRecord

__all__ = [
    "__version__", "Domain", "Grid", "PointSet", "Polylines", "TriMesh", "register_domain_kind",
    "ProcgenError", "RecipeError", "PluginError", "InputError", "MissingExtra", "Exporter", "FieldName",
    "write", "FieldSpec",
    "hookimpl", "hookspec", "param", "PluginHost", "get_plugin_manager", "Recipe", "check_recipe",
    "load_recipe", "Rule", "RuleBase", "RunResult", "run", "State", "StepRecord",
]

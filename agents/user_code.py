"""A user's function named ``module:function``, imported from the working directory or ``sys.path``.

``deadtime process --process module:factory`` and ``deadtime frontier --policies module:function`` take one;
importing it runs the module's code, so name only your own.  What goes wrong (the module does not import,
it has no such function) is one ``ValueError`` that names the option.
"""

from __future__ import annotations

import os
import sys
from importlib import import_module
from typing import Any, Callable

__all__ = ["user_function"]


def user_function(target: str, option: str) -> Callable[..., Any]:
    """The callable ``function`` of ``module`` in ``target = "module:function"``; ``option`` (e.g. ``--process``)
    heads the error's one line."""
    module_name, _, function_name = target.partition(":")
    if os.getcwd() not in sys.path:
        sys.path.append(os.getcwd())
    try:
        module = import_module(module_name)
    except Exception as error:  # noqa: BLE001  (whatever the user's module raises on import is bad input)
        raise ValueError(f"{option}: cannot import {module_name!r} ({type(error).__name__}: {error})") from None
    function = getattr(module, function_name, None)
    if not callable(function):
        raise ValueError(f"{option}: module {module_name!r} has no function {function_name!r}")
    return function

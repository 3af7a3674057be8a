"""The environment pages, docs/environments/<name>.md, generated from the environments themselves.

One page per registered ``DeadTime`` environment name (``DeadTime/PID-v0`` .. ``-v3`` make
``pid.md``), written from the class docstring of its entry point (Gymnasium's format: Description,
Action Space, Observation Space, Rewards, Starting State, Episode End, Arguments, Info, Version
History) and from the newest registered version made in each mode: the spaces' shapes, the
experiments offered, the observation's entries index by index (described by the docstring's table
of features) and every argument's default (the registered keyword arguments over the constructor's).
A section whose text is the shared one of :mod:`envs.env_cards` (``SHARED_DOC``, ``VERSION_HISTORY``)
is written once, on ``common.md``, and the structure's page links to it; the page keeps what is the
structure's own (its Description, its observation index by index, its defaults, its own history).
So the docstring is the one text, and a new environment gets its page by rerunning::

    python -m agents.environment_pages            # writes docs/environments/*.md
    python -m agents.environment_pages --check    # exit status 1 if a page differs from its source

``tests/unit/test_environment_pages.py`` fails when a committed page is stale.
"""

from __future__ import annotations

import inspect
import json
import re
import sys
from collections.abc import Sequence
from dataclasses import fields, is_dataclass
from pathlib import Path
from typing import Any

from agents.files.writer import write_text

__all__ = ["COMMON", "NAMESPACE", "PAGES", "common_page", "environment_names", "main", "page", "pages", "write_pages"]

NAMESPACE = "DeadTime"
PAGES = Path(__file__).resolve().parents[1] / "docs" / "environments"
"""Where the pages are written: one ``<name>.md`` per environment name, in lower case."""
COMMON = "common.md"
"""The page of the sections every structure's docstring shares."""
MODES = ("fixed", "plan", "agent")
COMMAND = "python -m agents.environment_pages"
_ROLE = re.compile(r":(?:mod|func|class|data|meth|attr):`~?([^`]+)`")


def _registry() -> dict[str, Any]:
    import gymnasium

    import envs  # noqa: F401  (registers the ids)

    return {key: spec for key, spec in gymnasium.registry.items() if spec.namespace == NAMESPACE}


def environment_names() -> dict[str, list[Any]]:
    """``{name: its specs, oldest version first}`` of every registered ``DeadTime`` id."""
    names: dict[str, list[Any]] = {}
    for spec in _registry().values():
        names.setdefault(spec.name, []).append(spec)
    return {name: sorted(specs, key=lambda spec: spec.version or 0) for name, specs in sorted(names.items())}


def _markdown(text: str) -> str:
    """Docstring markup as Markdown: ````x```` and ``:role:`x``` as ```x```."""
    return _ROLE.sub(r"`\1`", text.replace("``", "`"))


def _sections(doc: str) -> tuple[str, dict[str, str]]:
    """The docstring's first line, and its ``## `` sections by title (in order)."""
    lines = inspect.cleandoc(doc).splitlines()
    title, sections, current = lines[0].strip().rstrip("."), {}, None
    for line in lines[1:]:
        if line.startswith("## "):
            current = line[3:].strip()
            sections[current] = []
        elif current is not None:
            sections[current].append(line)
    return title, {name: "\n".join(body).strip() for name, body in sections.items()}


def _shared_sections() -> dict[str, str]:
    """The sections of :mod:`envs.env_cards` that the structures' docstrings share, by title."""
    from envs.env_cards import SHARED_DOC, VERSION_HISTORY

    return _sections("shared\n" + SHARED_DOC + VERSION_HISTORY)[1]


def _anchor(title: str) -> str:
    """GitHub's anchor of a heading."""
    return re.sub(r"[^\w\- ]", "", title.lower()).replace(" ", "-")


def _common_link(title: str) -> str:
    return f"[{title}]({COMMON}#{_anchor(title)})"


def _cell(text: str) -> str:
    """A table cell's text as Markdown, its own ``|`` escaped (GitHub splits cells at every bare one)."""
    return _markdown(text).replace("\\|", "|").replace("|", "\\|")


def _table(text: str) -> tuple[str, list[list[str]], str]:
    """The prose before a section's Markdown table of three columns (the third may hold ``|``), its rows (cells stripped, header and
    rule left out) and the prose after it."""
    lines = text.splitlines()
    rows = [i for i, line in enumerate(lines) if line.lstrip().startswith("|")]
    if not rows:
        return text, [], ""
    first, last = rows[0], rows[-1]
    cells = [[cell.strip() for cell in lines[i].strip().strip("|").split("|", 2)] for i in range(first + 2, last + 1)]
    return "\n".join(lines[:first]).strip(), cells, "\n".join(lines[last + 1:]).strip()


def _rendered(text: str) -> list[str]:
    """A section's text with its table rewritten compactly (cells as Markdown, their ``|`` escaped)."""
    before, rows, after = _table(text)
    if not rows:
        return [_markdown(text)]
    header_line = next(line for line in text.splitlines() if line.lstrip().startswith("|"))
    header = [cell.strip() for cell in header_line.strip().strip("|").split("|")]
    out = [_markdown(before), ""] if before else []
    out += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(_cell(cell) for cell in row) + " |" for row in rows]
    return [*out, "", _markdown(after)] if after else out


def _make(spec: Any, **kwargs: Any) -> Any:
    import gymnasium

    from envs.interface import tuning_env_of

    env = gymnasium.make(spec.id, disable_env_checker=True, **kwargs)
    try:
        return tuning_env_of(env)
    finally:
        env.close()


def _shape(space: Any) -> str:
    return str(tuple(space.shape))


def _value(value: Any) -> str:
    """An argument's default as Python would write it (a dataclass by its fields)."""
    if is_dataclass(value):
        inner = ", ".join(f"{f.name}={getattr(value, f.name)!r}" for f in fields(value))
        return f"`{type(value).__name__}({inner})`"
    if isinstance(value, dict):
        return f"`{json.dumps(value)}`"
    return f"`{value!r}`".replace("'", '"')


def _defaults(spec: Any, entry_point: type, env: Any) -> dict[str, Any]:
    """Every argument's default in ``spec``: the registered keyword arguments over the constructor's;
    those the environment completes (the family, the constraints and the weights) as the made ``env`` holds them."""
    config = getattr(entry_point, "config_class", None)  # the arguments as one dataclass (envs.env_config.EnvConfig)
    if config is not None:
        defaults = config.defaults()
    else:
        defaults = {name: parameter.default for name, parameter in inspect.signature(entry_point.__init__).parameters.items()
                    if name != "self" and parameter.default is not inspect.Parameter.empty}
    defaults.update(spec.kwargs)
    for name in ("family", "constraints", "weights"):
        if name in defaults and getattr(env, name, None) is not None:
            defaults[name] = getattr(env, name)
    return defaults


def _header(specs: Sequence[Any], envs: dict[str, Any], linked: Sequence[str]) -> list[str]:
    latest = specs[-1]
    action, observation = envs["fixed"].action_space, envs["fixed"].observation_space
    others = [f"{mode} mode `{_shape(envs[mode].action_space)}`" for mode in MODES[1:]]
    observed = [f"{mode} mode `{_shape(envs[mode].observation_space)}`" for mode in MODES[1:]
                if envs[mode].observation_space.shape != observation.shape]
    entry = latest.entry_point if isinstance(latest.entry_point, str) else latest.entry_point.__module__
    return [
        "| | |",
        "|---|---|",
        f"| Action Space | `{action}` (fixed mode; {', '.join(others)}) |",
        f"| Observation Space | `{observation}` (fixed mode{'; ' + ', '.join(observed) if observed else ''}) |",
        f"| import | `import envs; gymnasium.make(\"{latest.id}\")` |",
        f"| class | `{entry.replace(':', '.')}` |",
        f"| versions | {', '.join(f'`{spec.id}`' for spec in specs)} |",
        "",
        f"The shapes and defaults are those of `{latest.id}`; the versions differ in their defaults (Version",
        f"History).  Modes, vector environment, determinism and threads: [overview.md](overview.md).  The",
        f"sections every structure shares are on [{COMMON}]({COMMON}), here only linked: "
        + ", ".join(_common_link(title) for title in linked) + ".",
    ]


def _experiments(envs: dict[str, Any], every: Any) -> str:
    offered = ", ".join(f"`{name}`" for name in envs["agent"].experiment_names)
    line = f"Agent mode here offers {len(envs['agent'].experiment_names)} experiment types: {offered}"
    extra = [name for name in every.experiment_names if name not in envs["agent"].experiment_names]
    if extra:
        line += f"; with `experiment_set=\"all\"` also {', '.join(f'`{name}`' for name in extra)}"
    return line + "."


def _discrete(spec: Any) -> str:
    """The discrete action's space in agent mode, or nothing where the version has no design step."""
    try:
        env = _make(spec, experiments="agent", discrete_action=True)
    except (TypeError, ValueError):
        return ""
    return f"  With `discrete_action=True`: `{env.action_space}`."


def _observation(text: str, envs: dict[str, Any], every: Any, version: str, shared: bool) -> list[str]:
    """The section's prose (a link where it is the shared one), then the observation index by index,
    each entry described by the docstring's table of features (``count_<type>`` for the counts)."""
    before, rows, after = _table(text)
    described = {row[0].strip("`"): row for row in rows}
    offered, possible = set(envs["agent"].experiment_names), set(every.experiment_names)
    index = f"Index by index in {version} (agent mode; the fixed mode has no `design_step`)"
    if shared:
        out = [f"{index}; what the entries are and when they are 0: {_common_link('Observation Space')}.", ""]
    else:
        out = [_markdown(before), "", f"{index}:", ""]
    out += ["| index | name | value |", "|---|---|---|"]
    for index, name in enumerate(envs["agent"].feature_names):
        key = "count_<type>" if name.startswith("count_") else name
        if key not in described:
            raise ValueError(f"the docstring's table of features does not describe {name!r}")
        _, source, value = described[key]
        source = source.strip("`")
        if source not in ("", "-") and source not in possible:
            value += f"; measured by the {source}, which these plants do not run: 0 here"
        elif source not in ("", "-") and source not in offered:
            value += f"; measured by the {source}, which {version} does not offer: 0 unless `experiment_set=\"all\"`"
        out.append(f"| {index} | `{name}` | {_cell(value)} |")
    return [*out, "", _markdown(after)] if after and not shared else out


def _call(spec_id: str, arguments: dict[str, Any], width: int = 100) -> list[str]:
    """``gymnasium.make(spec_id, name=value, ...)`` wrapped at ``width``, each argument on one line."""
    items = [f"{name}={_value(value).strip('`')}," for name, value in arguments.items()]
    items[-1] = items[-1].rstrip(",") + ")"
    lines, indent = [f'gymnasium.make("{spec_id}",'], " " * len("gymnasium.make(")
    for item in items:
        if len(lines) > 1 and len(lines[-1]) + 1 + len(item) <= width:
            lines[-1] += " " + item
        else:
            lines.append(indent + item)
    return lines


def _arguments(text: str, defaults: dict[str, Any], version: str, spec_id: str, shared: bool) -> list[str]:
    """The arguments' defaults in ``version``; their meanings too where the section is not the shared one."""
    before, rows, after = _table(text)
    meanings = {row[0].strip("`"): row[-1] for row in rows}
    missing = sorted(set(defaults) - set(meanings))
    if missing:
        raise ValueError(f"the docstring's Arguments table does not describe {', '.join(missing)}")
    if shared:
        return [f"What each argument means, and its default in each version: {_common_link('Arguments')}.  The defaults",
                f"in {version}:", "", "```python", *_call(spec_id, {name: defaults[name] for name in meanings if name in defaults}), "```"]
    out = [_markdown(before), ""] if before else []
    out += [f"| argument | default in {version} | meaning |", "|---|---|---|"]
    out += [f"| `{name}` | {_cell(_value(defaults[name]))} | {_cell(meanings[name])} |" for name in meanings if name in defaults]
    return [*out, "", _markdown(after)] if after else out


def page(name: str, specs: Sequence[Any]) -> str:
    """The Markdown page of environment ``name`` (its registered ``specs``, oldest first): its own
    sections in full, the shared ones (:func:`common_page`) as links."""
    from gymnasium.envs.registration import load_env_creator

    latest = specs[-1]
    entry_point = load_env_creator(latest.entry_point) if isinstance(latest.entry_point, str) else latest.entry_point
    title, sections = _sections(entry_point.__doc__ or "")
    common = _shared_sections()
    envs = {mode: _make(latest, experiments=mode) for mode in MODES}
    every = _make(latest, experiments="agent", experiment_set="all")
    version = f"v{latest.version}"
    lines = [f"# {name}: {_markdown(title)}", "",
             f"<!-- Generated by `{COMMAND}` from the docstring of `{entry_point.__module__}.{entry_point.__name__}` "
             "and the registered ids: edit those and rerun it. -->", ""]
    own = ("Description", "Action Space", "Observation Space", "Arguments")  # sections with what is the structure's own
    linked = [section for section, text in sections.items() if common.get(section) == text and section not in own]
    lines += _header(specs, envs, linked)
    for section, text in sections.items():
        if section in linked:
            continue
        shared = common.get(section) == text
        lines += ["", f"## {section}", ""]
        if section == "Observation Space":
            lines += _observation(text, envs, every, version, shared)
        elif section == "Arguments":
            lines += _arguments(text, _defaults(latest, entry_point, envs["fixed"]), version, latest.id, shared)
        elif section == "Action Space":
            offered = _experiments(envs, every) + _discrete(latest)
            lines += ([f"{offered}  The action in each mode, and the discrete action: {_common_link('Action Space')}."]
                      if shared else [_markdown(text), "", offered])
        else:
            lines.append(_markdown(text))
    return "\n".join(lines).rstrip() + "\n"


def common_page(names: dict[str, list[Any]]) -> str:
    """The page of the sections that the docstrings of the environments ``names`` share."""
    from gymnasium.envs.registration import load_env_creator

    common = _shared_sections()
    users: dict[str, list[str]] = {section: [] for section in common}
    for name, specs in names.items():
        entry = specs[-1].entry_point
        _, sections = _sections((load_env_creator(entry) if isinstance(entry, str) else entry).__doc__ or "")
        for section, text in sections.items():
            if common.get(section) == text:
                users[section].append(name)
    pages = ", ".join(f"[{name.lower()}.md]({name.lower()}.md)" for name in names)
    lines = ["# The sections every structure shares", "",
             f"<!-- Generated by `{COMMAND}` from `envs.env_cards` (SHARED_DOC, VERSION_HISTORY): edit those and rerun it. -->",
             "", "Each structure's class docstring ends with these sections (Gymnasium's format); its own page gives",
             f"the rest (its Description, its observation index by index, its defaults): {pages}.",
             "The versions: " + "; ".join(f"{name} {', '.join(f'v{spec.version}' for spec in specs)}"
                                          for name, specs in names.items()) + "."]
    for section, text in common.items():
        lines += ["", f"## {section}", ""]
        if len(users[section]) < len(names):
            lines += [f"Of {', '.join(users[section])}.", ""]
        lines += _rendered(text)
    return "\n".join(lines).rstrip() + "\n"


def pages() -> dict[Path, str]:
    """Every environment's page by its path."""
    names = environment_names()
    return {PAGES / COMMON: common_page(names), **{PAGES / f"{name.lower()}.md": page(name, specs) for name, specs in names.items()}}


def write_pages() -> list[Path]:
    """Write every page that differs from what :func:`pages` makes; the paths written."""
    written = []
    for path, text in pages().items():
        if not path.is_file() or path.read_text() != text:
            write_text(path, text)
            written.append(path)
    return written


def main(argv: Sequence[str] | None = None) -> int:
    """Write the pages (exit status 0), or with ``--check`` only compare (exit status 1 if one is stale)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv not in ([], ["--check"]):
        print(f"usage: {COMMAND} [--check]", file=sys.stderr)
        return 2
    if argv:
        stale = [path for path, text in pages().items() if not path.is_file() or path.read_text() != text]
        for path in stale:
            print(f"{path.relative_to(PAGES.parents[1])} is stale; regenerate it with: {COMMAND}", file=sys.stderr)
        return 1 if stale else 0
    for path in write_pages():
        print(f"wrote {path.relative_to(PAGES.parents[1])}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

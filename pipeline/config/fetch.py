"""Section `fetch` of params.yaml: the raw-data sources and the places they are fetched from, and
how a location is read: a mirror (a folder or an http(s) base URL) or each source's own upstream
layout (`UpstreamLocation`, with its path rules). `pipeline.data.fetch` fetches with them."""

from __future__ import annotations

import urllib.parse
from dataclasses import dataclass, field
from typing import Any


FETCH_SOURCES = ("sdd", "ynet-release", "sgan", "trajnet-sdd", "ethucy-scenes")


@dataclass
class FetchParams:
    sources: list[str] = field(default_factory=lambda: list(FETCH_SOURCES))
    """Sources to fetch; one `fetch@<source>` stage each."""
    locations: list[str | dict] = field(default_factory=lambda: ["../shared/data"])
    """Ordered places to try. A string is a mirror, a local folder or an http(s) base URL holding
    `<base>/<source>/<rel>`. A mapping `{name, sources: {<source>: {base, map}}}` says where each
    source lies upstream, in another layout (`UpstreamLocation`); `parsed_locations` reads both."""
    timeout_s: float = 60.0
    """Per-request timeout for http(s) locations."""

    def __post_init__(self):
        unknown = sorted(set(self.sources) - set(FETCH_SOURCES))
        if unknown:
            raise ValueError(f"unknown source(s) {unknown}; known: {list(FETCH_SOURCES)}")
        if not self.locations:
            raise ValueError("locations: at least one location is needed")
        names = [loc.name for loc in self.parsed_locations() if isinstance(loc, UpstreamLocation)]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ValueError(f"locations: upstream name(s) {twice} used twice; names tell them apart "
                             "in error messages")

    def parsed_locations(self) -> list[str | UpstreamLocation]:
        """`locations` checked and typed: strings stay, mappings become `UpstreamLocation`s. The
        raw YAML stays in `locations` (so params.yaml round-trips); this parses it on demand."""
        return [parse_location(entry, f"locations[{i}]") for i, entry in enumerate(self.locations)]


def is_url(location: str) -> bool | None:
    """True for http(s) URLs, False for local paths, None for other schemes (rejected)."""
    scheme = urllib.parse.urlparse(location).scheme
    if scheme in ("http", "https"):
        return True
    if scheme in ("", "file") or len(scheme) == 1:  # "C:" on Windows counts as a path
        return False
    return None


@dataclass(frozen=True)
class PathRule:
    """One rewrite of a manifest path: `prefix` (YAML `from`) is replaced by `to`, under `base`
    when given (a source split across folders or repositories), else under the source's base.

    A `prefix` ending in "/" is a folder and rewrites every path under it; any other non-empty
    `prefix` is one file and matches that path only (so `eth/` never catches `eth_ucy/...`); the
    empty prefix matches every path."""

    prefix: str
    to: str
    base: str | None = None

    def matches(self, rel: str) -> bool:
        folder = self.prefix == "" or self.prefix.endswith("/")
        return rel == self.prefix or (folder and rel.startswith(self.prefix))

    def apply(self, rel: str) -> str:
        return self.to + rel[len(self.prefix):]


@dataclass(frozen=True)
class UpstreamSource:
    """Where one source lies upstream: manifest path -> `<base>/<rewritten path>`."""

    base: str
    rules: tuple[PathRule, ...]

    def resolve(self, rel: str) -> str | None:
        """The upstream address (URL or local path) of manifest path `rel`, by the first rule that
        matches it; None when no rule does (the file is not offered)."""
        for rule in self.rules:
            if rule.matches(rel):
                return join_address(rule.base or self.base, rule.apply(rel))
        return None


@dataclass(frozen=True)
class UpstreamLocation:
    """A named location that holds each source it lists in that source's own upstream layout."""

    name: str
    sources: dict[str, UpstreamSource]


def join_address(base: str, path: str) -> str:
    """`base` + "/" + `path`, for a URL base (`path` percent-quoted, `base` taken as written) or a
    local folder; `path` is relative and "/"-separated."""
    if not path:
        return base.rstrip("/")
    return base.rstrip("/") + "/" + (urllib.parse.quote(path) if is_url(base) else path)


def _check_keys(value: Any, where: str, required: set[str], optional: set[str] = frozenset()) -> dict:
    if not isinstance(value, dict):
        raise ValueError(f"{where}: expected a mapping, got {type(value).__name__} {value!r}")
    unknown = sorted(set(map(str, value)) - required - optional)
    missing = sorted(required - set(value))
    if unknown or missing:
        raise ValueError(f"{where}: " + "; ".join(
            ([f"unknown key(s) {unknown}"] if unknown else [])
            + ([f"missing key(s) {missing}"] if missing else []))
            + f"; allowed: {sorted(required | optional)}")
    return value


def _check_base(base: Any, where: str) -> str:
    if not isinstance(base, str) or not base or is_url(base) is None:
        raise ValueError(f"{where}: {base!r} is not a folder path or an http(s) URL")
    return base


def _check_rel(value: Any, where: str) -> str:
    """A relative "/"-separated path or prefix: no leading "/", no "." or ".." segment, no "\\"."""
    if not isinstance(value, str):
        raise ValueError(f"{where}: expected a string, got {type(value).__name__} {value!r}")
    segments = value.rstrip("/").split("/") if value else []
    if value.startswith("/") or "\\" in value or any(s in ("", ".", "..") for s in segments):
        raise ValueError(f"{where}: {value!r} must be a relative path like 'a/b/' or 'a/b.txt' "
                         "(no leading '/', no '.', '..' or empty segment, no '\\')")
    return value


def parse_rule(raw: Any, where: str) -> PathRule:
    raw = _check_keys(raw, where, {"from", "to"}, {"base"})
    prefix, to = _check_rel(raw["from"], f"{where}.from"), _check_rel(raw["to"], f"{where}.to")
    folder = prefix == "" or prefix.endswith("/")
    if folder and not (to == "" or to.endswith("/")):
        raise ValueError(f"{where}: folder {prefix!r} must map to a folder ending in '/' (or ''), "
                         f"got {to!r}")
    if not folder and (to == "" or to.endswith("/")):
        raise ValueError(f"{where}: file {prefix!r} must map to a file path, got {to!r}")
    base = raw.get("base")
    return PathRule(prefix, to, None if base is None else _check_base(base, f"{where}.base"))


def parse_upstream_source(raw: Any, where: str) -> UpstreamSource:
    """A source's `{base, map}`; `map` left out means paths are the same upstream (`from: ''`)."""
    raw = _check_keys(raw, where, {"base"}, {"map"})
    base = _check_base(raw["base"], f"{where}.base")
    rules_raw = raw.get("map", [{"from": "", "to": ""}])
    if not isinstance(rules_raw, list) or not rules_raw:
        raise ValueError(f"{where}.map: expected a non-empty list of {{from, to[, base]}} rules")
    rules = tuple(parse_rule(r, f"{where}.map[{i}]") for i, r in enumerate(rules_raw))
    for later, rule in enumerate(rules):
        for earlier in range(later):
            if rules[earlier].matches(rule.prefix):
                raise ValueError(f"{where}.map[{later}] (from {rule.prefix!r}) is never used: "
                                 f"map[{earlier}] (from {rules[earlier].prefix!r}) matches its paths first")
    return UpstreamSource(base, rules)


def parse_location(raw: Any, where: str) -> str | UpstreamLocation:
    """A `fetch.locations` entry, checked: a mirror (string) or an upstream mapping."""
    if isinstance(raw, str):
        if is_url(raw) is None:
            raise ValueError(f"location {raw!r}: not a folder path or an http(s) URL")
        return raw
    raw = _check_keys(raw, where, {"name", "sources"})
    if not isinstance(raw["name"], str) or not raw["name"]:
        raise ValueError(f"{where}.name: expected a non-empty string, got {raw['name']!r}")
    where = f"{where} ({raw['name']})"
    if not isinstance(raw["sources"], dict) or not raw["sources"]:
        raise ValueError(f"{where}.sources: expected a mapping of source -> {{base, map}}")
    unknown = sorted(set(map(str, raw["sources"])) - set(FETCH_SOURCES))
    if unknown:
        raise ValueError(f"{where}.sources: unknown source(s) {unknown}; known: {list(FETCH_SOURCES)}")
    return UpstreamLocation(raw["name"], {
        source: parse_upstream_source(spec, f"{where}.sources.{source}")
        for source, spec in raw["sources"].items()})

"""Which physics terms a fit adds, and which of their parameters it frees.

`--terms friction,compressibility` adds those terms with the parameters each declares
free (`Param.free`); `term.param` also frees a parameter a term holds by default
(`sensor_lag.load_cell_lag_s`). `none` fits the paper's model alone. The default,
`sensor_lag`, frees the channel delay, as every fit did before terms existed.
"""

from __future__ import annotations

from dataclasses import dataclass

from shockdyno.errors import ConfigError
from shockdyno.model.composite import Term
from shockdyno.model.terms import LIBRARY, make_term

DEFAULT_TERMS = "sensor_lag"


@dataclass(frozen=True)
class TermSelection:
    terms: tuple[Term, ...]
    free: tuple[str, ...]  # qualified names of the parameters the fit estimates

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(t.name for t in self.terms)


def split_terms(text: str) -> list[str]:
    """The one `--terms` grammar of fit and diagnose: comma-separated names, none empty.
    An empty list ("", ",", "a,,b") is an error, not a silent "none" or "all"."""
    items = [s.strip() for s in text.split(",")]
    if not any(items):
        raise ConfigError(
            f"--terms {text!r}: an empty list (give term names such as friction,sensor_lag; "
            f"the library: {', '.join(LIBRARY)})"
        )
    if not all(items):
        raise ConfigError(f"--terms {text!r}: an empty name between commas")
    return items


def parse_terms(text: str | None) -> TermSelection:
    """Parse `--terms`; unknown names are one-line ConfigErrors naming the library."""
    items = split_terms(DEFAULT_TERMS if text is None else text)
    if items == ["none"]:
        return TermSelection((), ())
    terms: dict[str, Term] = {}
    free: list[str] = []
    for item in items:
        name, _, local = item.partition(".")
        if name not in LIBRARY:
            raise ConfigError(f"--terms: unknown term {name!r} (one of {', '.join(LIBRARY)})")
        term = terms.setdefault(name, make_term(name))
        declared = {p.name: p for p in term.params()}
        if local:
            if local not in declared:
                raise ConfigError(
                    f"--terms: {name} has no parameter {local!r} (one of {', '.join(declared)})"
                )
            chosen = [local]
        else:
            chosen = [p.name for p in term.params() if p.free]
        free += [term.qualified(k) for k in chosen if term.qualified(k) not in free]
    return TermSelection(tuple(terms.values()), tuple(free))

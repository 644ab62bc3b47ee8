"""State: the named domains a recipe works on, its seed, per-rule random streams and records."""
from __future__ import annotations

import io
import json
import zlib
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from .ca.cells import kind_accepts, kind_text
from .domains import DOMAIN_KINDS, Domain
from .errors import InputError

FORMAT_VERSION = 1
D = TypeVar("D", bound=Domain)


@dataclass
class StepRecord:
    """What one iteration of one rule did."""

    step: int
    rule: str
    iteration: int
    changed: bool
    seconds: float


def _rule_key(rule_name: str) -> int:
    """A stable 32-bit key for a rule name (Python's hash() is salted per process)."""
    return zlib.crc32(rule_name.encode("utf-8"))


@dataclass
class State:
    """Everything a recipe builds: domains by name, the seed and what happened.

    Random numbers come only from :meth:`rng`, derived from (seed, step index, rule name,
    iteration), so editing one step's parameters never reshuffles another step's stream.
    """

    seed: int = 0
    domains: dict[str, Domain] = field(default_factory=dict)
    records: list[StepRecord] = field(default_factory=list)
    reports: dict[str, Any] = field(default_factory=dict)
    step_index: int = 0
    rule_name: str = ""
    iteration: int = -1
    base_dir: Path | None = None

    # -- domains --------------------------------------------------------------------------
    def add_domain(self, name: str, domain: Domain) -> Domain:
        if not isinstance(domain, Domain):
            raise InputError(f"domain {name!r}: {type(domain).__name__} is not a procgen Domain")
        self.domains[name] = domain
        return domain

    def get(self, name: str, kind: type[D] | str | None = None) -> D:
        """The domain called ``name``, checked to be of ``kind`` (a class or kind name)."""
        dom = self.domains.get(name)
        if dom is None:
            have = ", ".join(sorted(self.domains)) or "none"
            raise InputError(f"no domain {name!r} in the state (domains: {have})")
        if kind is not None:
            kname = kind if isinstance(kind, str) else kind.kind
            if not kind_accepts(type(dom), kname):
                raise InputError(f"domain {name!r} is a {dom.kind}, expected a {kind_text(kname)}")
        return dom  # type: ignore[return-value]

    def __contains__(self, name: object) -> bool:
        return name in self.domains

    # -- randomness -----------------------------------------------------------------------
    def rng(self, stream: int = 0) -> np.random.Generator:
        """The generator of the current rule and iteration (``stream`` picks a sub-stream)."""
        seq = np.random.SeedSequence(
            entropy=int(self.seed) & 0xFFFFFFFFFFFFFFFF,
            spawn_key=(int(self.step_index), _rule_key(self.rule_name), int(self.iteration) + 1, int(stream)))
        return np.random.Generator(np.random.PCG64(seq))

    # -- reports --------------------------------------------------------------------------
    def report(self, key: str, value: Any) -> None:
        """Record a number (or small JSON-able value) for run.json, e.g. ``N_s``."""
        if isinstance(value, np.generic):
            value = value.item()
        self.reports[key] = value

    # -- persistence ----------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        """Write every domain and field as one NPZ (arrays) with a JSON header (versioned)."""
        from .exchange import write

        write(Path(path), self.to_npz_bytes())

    def to_npz_bytes(self) -> bytes:
        arrays: dict[str, np.ndarray] = {}
        header: dict[str, Any] = {"format": "procgen-state", "version": FORMAT_VERSION,
                                  "seed": int(self.seed), "reports": self.reports,
                                  "records": [{k: v for k, v in asdict(r).items() if k != "seconds"} for r in self.records], "domains": {}}
        for dname, dom in self.domains.items():
            topo = dom.topology_arrays()
            for k, arr in topo.items():
                arrays[f"{dname}/@{k}"] = np.asarray(arr)
            finfo = {}
            for fname, arr, info in dom.fields():
                arrays[f"{dname}/{fname}"] = np.asarray(arr)
                finfo[fname] = {"at": info.at, "units": info.units, "doc": info.doc}
            header["domains"][dname] = {"kind": dom.kind, "meta": dom.topology_meta(),
                                        "topology": sorted(topo), "fields": finfo}
        arrays["__header__"] = np.frombuffer(json.dumps(header, sort_keys=True).encode(), dtype=np.uint8)
        buf = io.BytesIO()
        np.savez_compressed(buf, **arrays)
        return _strip_zip_times(buf.getvalue())

    @classmethod
    def load(cls, path: str | Path) -> "State":
        try:
            with np.load(Path(path), allow_pickle=False) as npz:
                data = {k: npz[k] for k in npz.files}
        except (OSError, ValueError) as exc:
            raise InputError(f"{path}: not a procgen state file ({exc})") from None
        if "__header__" not in data:
            raise InputError(f"{path}: not a procgen state file (no header)")
        header = json.loads(bytes(data["__header__"]).decode())
        if header.get("format") != "procgen-state" or header.get("version", 0) > FORMAT_VERSION:
            raise InputError(f"{path}: unsupported state format/version {header.get('version')}")
        st = cls(seed=header["seed"], reports=header.get("reports", {}))
        st.records = [StepRecord(seconds=0.0, **r) for r in header.get("records", [])]
        for dname, dinfo in header["domains"].items():
            klass = DOMAIN_KINDS.get(dinfo["kind"])
            if klass is None:
                raise InputError(f"{path}: domain {dname!r} has unknown kind {dinfo['kind']!r} "
                                 "(is its plugin installed?)")
            topo = {k: data[f"{dname}/@{k}"] for k in dinfo["topology"]}
            dom = klass.from_topology(topo, dinfo["meta"])
            for fname, fi in dinfo["fields"].items():
                dom.add_field(fname, data[f"{dname}/{fname}"], at=fi["at"], units=fi["units"], doc=fi["doc"])
            st.add_domain(dname, dom)
        return st


def _strip_zip_times(blob: bytes) -> bytes:
    """Re-pack a zip with fixed member timestamps so equal states give equal bytes."""
    import zipfile

    src = zipfile.ZipFile(io.BytesIO(blob))
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as dst:
        for item in src.infolist():
            info = zipfile.ZipInfo(item.filename, date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            dst.writestr(info, src.read(item.filename))
    return out.getvalue()

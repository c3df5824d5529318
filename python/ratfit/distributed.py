"""Fitting a database of materials on a Dask cluster.

:func:`fit_many` submits one task per material and channel (the three
functions of a fit are independent) and one that joins them, to a
``dask.distributed`` client: a ``LocalCluster`` on one machine, or a
scheduler that workers on many machines joined. Results come back as
:class:`~ratfit.RationalFit` and :class:`~ratfit.FittedMaterial` objects; a
task that fails is reported with its error and the others are kept.

    >>> from dask.distributed import Client, LocalCluster          # doctest: +SKIP
    >>> client = Client(LocalCluster(n_workers=2, threads_per_worker=1))
    >>> results = fit_many(paths, {"format": "rgl", "rel_tol": 0.1}, client)
    >>> [r.fitted.nbytes for r in results if r.ok]

On a cluster, start ``dask scheduler`` on one machine and ``dask worker
tcp://SCHEDULER:8786`` on each of the others (each with ``ratfit`` installed
and the material files at the same paths, on shared storage), then pass
``Client("tcp://SCHEDULER:8786")``: the call is the same.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

from . import _ratfit
from ._ratfit import FittedMaterial, RationalFit

__all__ = ["fit_many", "MaterialResult"]


@dataclass
class MaterialResult:
    """What the tasks of one material returned.

    Attributes:
        path: the material file.
        channels: the three fitted functions in the colour mode's order
            (None where that task failed); empty for ``target_de`` fits, which
            fit the material whole.
        channel_reports: each channel's report (dict), None where it failed.
        fitted: the joined fit, None when a task failed.
        errors: task name ("channel 0", "channel 1", "channel 2", "join" or
            "material") to "ExceptionType: message".
    """

    path: str
    channels: List[Optional[RationalFit]] = field(default_factory=list)
    channel_reports: List[Optional[Dict[str, Any]]] = field(default_factory=list)
    fitted: Optional[FittedMaterial] = None
    errors: Dict[str, str] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """Every task of the material succeeded."""
        return self.fitted is not None and not self.errors


def _fit_channel(path: str, channel: int, settings: Dict[str, Any]) -> Tuple[RationalFit, Dict[str, Any]]:
    return _ratfit.fit_brdf_channel(path, channel, settings)


def _join(path: str, parts: Sequence[Tuple[RationalFit, Dict[str, Any]]], settings: Dict[str, Any]) -> FittedMaterial:
    return _ratfit.assemble_channels(path, list(parts), settings)


def _fit_whole(path: str, settings: Dict[str, Any]) -> FittedMaterial:
    return _ratfit.fit_brdf(path, settings)


def _describe(error: BaseException) -> str:
    return f"{type(error).__name__}: {error}"


def fit_many(
    paths: Sequence[str],
    settings: Optional[Mapping[str, Any]] = None,
    client: Any = None,
) -> List[MaterialResult]:
    """Fits every material of ``paths`` with the same ``fit_brdf`` settings.

    Args:
        paths: material files (MERL ``.binary``, RGL ``.bsdf``), at paths the
            workers can read.
        settings: keyword arguments of :func:`ratfit.fit_brdf` (``format``
            included), checked here before anything is submitted.
        client: a ``dask.distributed.Client``; default: the current one.

    Returns:
        One :class:`MaterialResult` per path, in order.
    """
    from dask.distributed import get_client, wait

    settings = dict(settings or {})
    # Refuse unknown options and bad values now, not in every task.
    _ratfit._check_brdf_options(settings)
    if client is None:
        client = get_client()
    whole = settings.get("target_de") is not None
    submitted = []
    for path in paths:
        path = str(path)
        if whole:
            submitted.append((path, [], client.submit(_fit_whole, path, settings, pure=False)))
            continue
        channel_futures = [
            client.submit(_fit_channel, path, c, settings, pure=False) for c in range(3)
        ]
        join = client.submit(_join, path, channel_futures, settings, pure=False)
        submitted.append((path, channel_futures, join))
    wait([f for _, cs, j in submitted for f in [*cs, j]])
    results = []
    for path, channel_futures, join in submitted:
        r = MaterialResult(path=path)
        for c, f in enumerate(channel_futures):
            if f.status == "finished":
                function, report = f.result()
                r.channels.append(function)
                r.channel_reports.append(report)
            else:
                r.channels.append(None)
                r.channel_reports.append(None)
                r.errors[f"channel {c}"] = _describe(f.exception())
        if join.status == "finished":
            r.fitted = join.result()
        elif not r.errors:
            r.errors["material" if whole else "join"] = _describe(join.exception())
        results.append(r)
    return results

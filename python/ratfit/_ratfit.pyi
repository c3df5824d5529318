"""Type stubs of the native module (the public API is re-exported by `ratfit`)."""

from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

class NoFeasibleFit(RuntimeError):
    """No split up to the maximum budget fits inside every interval."""

    max_coeffs: int
    widenings: int
    splits: List[Dict[str, Any]]

class RationalFit:
    """A rational function p / q fitted inside intervals."""

    def __call__(self, x: npt.ArrayLike) -> Union[float, npt.NDArray[np.float64]]: ...
    @property
    def n_p(self) -> int: ...
    @property
    def n_q(self) -> int: ...
    @property
    def dim(self) -> int: ...
    @property
    def numerator(self) -> npt.NDArray[np.float64]: ...
    @property
    def denominator(self) -> npt.NDArray[np.float64]: ...
    @property
    def domain(self) -> Tuple[List[float], List[float]]: ...
    @property
    def basis(self) -> str: ...
    @property
    def nbytes(self) -> int: ...
    @property
    def report(self) -> Optional[Dict[str, Any]]: ...
    def to_json(self) -> str: ...
    @staticmethod
    def from_json(text: str) -> "RationalFit": ...

class Material:
    """A measured table (MERL or RGL)."""

    def eval(self, wi: npt.ArrayLike, wo: npt.ArrayLike) -> npt.NDArray[np.float64]: ...
    @property
    def name(self) -> str: ...
    @property
    def path(self) -> str: ...

class FittedMaterial:
    """A material fitted by three rational functions (and an optional lobe)."""

    def eval(self, wi: npt.ArrayLike, wo: npt.ArrayLike) -> npt.NDArray[np.float64]: ...
    def export(self, kind: str) -> Union[str, bytes]: ...
    @property
    def channels(self) -> List[RationalFit]: ...
    @property
    def name(self) -> str: ...
    @property
    def coefficients(self) -> int: ...
    @property
    def nbytes(self) -> int: ...
    @property
    def report(self) -> Dict[str, Any]: ...
    def to_json(self) -> str: ...
    @staticmethod
    def from_json(text: str) -> "FittedMaterial": ...

def fit(
    x: npt.ArrayLike,
    y: Optional[npt.ArrayLike] = None,
    *,
    lo: Optional[npt.ArrayLike] = None,
    hi: Optional[npt.ArrayLike] = None,
    rel_tol: Optional[float] = None,
    abs_tol: Optional[float] = None,
    max_coeffs: int = 40,
    min_coeffs: int = 2,
    basis: str = "chebyshev",
    poles: str = "grid",
    search: str = "exhaustive",
    selection: str = "condition",
    degree_weights: Optional[Sequence[int]] = None,
    domain: Optional[Tuple[Sequence[float], Sequence[float]]] = None,
    max_widenings: int = 0,
    backend: str = "native",
    value_scaling: bool = True,
) -> RationalFit: ...
def read_material(path: str, format: Optional[str] = None) -> Material: ...
def fit_brdf(path: str, options: Optional[Dict[str, Any]] = None) -> FittedMaterial: ...
def fit_brdf_channel(
    path: str, channel: int, options: Optional[Dict[str, Any]] = None
) -> Tuple[RationalFit, Dict[str, Any]]: ...
def assemble_channels(
    path: str,
    parts: Sequence[Tuple[RationalFit, Dict[str, Any]]],
    options: Optional[Dict[str, Any]] = None,
) -> FittedMaterial: ...
def _check_brdf_options(options: Optional[Dict[str, Any]] = None) -> None: ...

"""Feature libraries: scikit-learn transformers applied to ``Z = [states, inputs]``."""

from ._base import BaseLibrary, ConcatLibrary, ExternalLibrary, ProductLibrary
from ._builtin import (
    AbsProductLibrary,
    FrictionLibrary,
    IndicatorLibrary,
    PolynomialLibrary,
    SqrtLibrary,
    TermsLibrary,
)
from ._custom import CustomLibrary, as_library
from ._spec import fitted_library_from_dict, fitted_library_to_dict, library_from_spec, library_to_spec
from ._terms import (
    ABS_POW,
    HINGE,
    LOGISTIC,
    POW,
    SIGN,
    SQRT,
    STEP,
    check_terms,
    evaluate_terms,
    evaluate_terms_jacobian,
    symbol_latex,
    term_latex,
    term_name,
    term_sympy,
    terms_from_json,
    terms_to_arrays,
    terms_to_json,
)

# the op codes, check_terms, evaluate_terms(_jacobian) and terms_to_arrays are exported from
# sindybench.dynamics and importable here too
__all__ = [
    "AbsProductLibrary",
    "BaseLibrary",
    "ConcatLibrary",
    "CustomLibrary",
    "ExternalLibrary",
    "FrictionLibrary",
    "IndicatorLibrary",
    "PolynomialLibrary",
    "ProductLibrary",
    "SqrtLibrary",
    "TermsLibrary",
    "as_library",
    "fitted_library_from_dict",
    "fitted_library_to_dict",
    "library_from_spec",
    "library_to_spec",
    "symbol_latex",
    "term_latex",
    "term_name",
    "term_sympy",
    "terms_from_json",
    "terms_to_json",
]

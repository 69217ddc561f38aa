"""The paper's experiments and the checks against closed forms: first contact of the tool
(``collision``, paper Table 2) and the opening of a cut in a prestressed sheet against linear
elastic fracture mechanics (``wound``)."""

from .collision import analytic_first_contact, mean_abs_error_pct, run_case, run_experiment, write_report

__all__ = ["analytic_first_contact", "mean_abs_error_pct", "run_case", "run_experiment", "write_report"]

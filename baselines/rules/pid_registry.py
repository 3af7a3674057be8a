"""The table of analytic PI/PID rules: name -> :class:`PIDFormula` (formulas in :mod:`baselines.rules.pid`).

Names are kebab-case, ``<rule>-<pi|pid>``; the Chien-Hrones-Reswick rules carry the objective and
the overshoot, ``chr-<setpoint|load>-<0|20>-<pi|pid>``.  :meth:`PIDFormula.design` gives the
controller for an identified model, computing the ultimate point first for the ultimate-gain rules.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import Callable, Literal

from baselines.rules import pid as rules
from envs.systems.controllers import PID, SeriesPID
from envs.identification.models import FOPDTModel, IntegratingModel, SOPDTModel
from envs.systems.plants import Plant

__all__ = ["PIDFormula", "RULES"]

ModelKind = Literal["fopdt", "sopdt", "ultimate"]

_CITATIONS = {
    "zn-step": "Ziegler & Nichols 1942; Marlin, Process Control, Table 10.5",
    "zn-ultimate": "Ziegler & Nichols 1942; Marlin, Process Control, Table 10.4",
    "cohen-coon": "Cohen & Coon 1953, Trans. ASME 75:827-834",
    "chr": "Chien, Hrones & Reswick 1952, Trans. ASME 74:175-185; table of Astrom & Hagglund 1995 ch. 4",
    "haalman": "Haalman 1965, Control Engineering 12(7):71-73 (loop 2 e^{-Ls}/(3Ls))",
    "amigo": "Astrom & Hagglund 2004, J. Process Control 14:635-650; Advanced PID Control 2006 ch. 7",
    "simc": "Skogestad 2003, J. Process Control 13:291-309 (tau_c = theta)",
    "isimc": "Grimholt & Skogestad 2012, IFAC PID'12, section 5 (tau_1 + theta/3)",
    "imc": "Rivera, Morari & Skogestad 1986, Ind. Eng. Chem. Process Des. Dev. 25:252-265, Table II; "
    "Chien & Fruehauf 1990 (integrating)",
}


@dataclass(frozen=True)
class PIDFormula:
    """One analytic PI/PID formula of the literature: the entry of :data:`RULES` that names it, says
    which model it needs and cites it.  The tuning environment's rules are
    :class:`baselines.rules.registry.Rule`, which wrap these.

    Attributes
    ----------
    name : str
        Registry key.
    function : callable
        The rule of :mod:`baselines.rules.pid` (for ``model="ultimate"`` a function of
        ``(K_u, T_u)``, otherwise of the model).
    model : {"fopdt", "sopdt", "ultimate"}
        What the rule needs: a FOPDT model, an SOPDT model (a FOPDT model is accepted as the SOPDT
        model with ``T_2 = 0``), or the ultimate gain and period (from any model).
    integrating : bool
        Whether the rule also accepts an :class:`~envs.identification.models.IntegratingModel`.
    form : {"ideal", "series"}
        The PID form the rule defines and returns (:class:`PID` or :class:`SeriesPID`).
    citation : str
        Source, table or equation.
    """

    name: str
    function: Callable[..., PID | SeriesPID]
    model: ModelKind
    integrating: bool
    form: Literal["ideal", "series"]
    citation: str

    def design(self, model: FOPDTModel | SOPDTModel | IntegratingModel | Plant) -> PID | SeriesPID:
        """The controller of this rule for ``model``.

        Raises
        ------
        ValueError
            If the model is not of a kind the rule accepts, or the rule is undefined for it.
        """
        if self.model == "ultimate":
            if isinstance(model, IntegratingModel) and not self.integrating:
                raise ValueError(f"rule {self.name} does not apply to integrating models")
            return self.function(*rules.ultimate_point(model))
        accepted: tuple[type, ...] = {"fopdt": (FOPDTModel,), "sopdt": (SOPDTModel, FOPDTModel)}[self.model]
        if self.integrating:
            accepted += (IntegratingModel,)
        if not isinstance(model, accepted):
            names = ", ".join(cls.__name__ for cls in accepted)
            raise ValueError(f"rule {self.name} needs one of {names}, got {type(model).__name__}")
        return self.function(model)


def _spec(name: str, function: Callable, model: ModelKind, integrating: bool, form: str, source: str) -> PIDFormula:
    return PIDFormula(name, function, model, integrating, form, _CITATIONS[source])


def _chr_specs() -> list[PIDFormula]:
    specs = []
    for objective in ("setpoint", "load"):
        for overshoot in (0, 20):
            for kind, function in (("pi", rules.chr_pi), ("pid", rules.chr_pid)):
                rule = partial(function, objective=objective, overshoot=overshoot)
                # the load rules use only a = K L/T and L, hence apply to integrating models
                name = f"chr-{objective}-{overshoot}-{kind}"
                specs.append(_spec(name, rule, "fopdt", objective == "load", "ideal", "chr"))
    return specs


RULES: dict[str, PIDFormula] = {
    spec.name: spec
    for spec in [
        _spec("zn-step-pi", rules.zn_step_pi, "fopdt", True, "ideal", "zn-step"),
        _spec("zn-step-pid", rules.zn_step_pid, "fopdt", True, "ideal", "zn-step"),
        _spec("zn-ultimate-pi", rules.zn_ultimate_pi, "ultimate", True, "ideal", "zn-ultimate"),
        _spec("zn-ultimate-pid", rules.zn_ultimate_pid, "ultimate", True, "ideal", "zn-ultimate"),
        _spec("cohen-coon-pi", rules.cohen_coon_pi, "fopdt", False, "ideal", "cohen-coon"),
        _spec("cohen-coon-pid", rules.cohen_coon_pid, "fopdt", False, "ideal", "cohen-coon"),
        *_chr_specs(),
        _spec("haalman-pid", rules.haalman_pid, "sopdt", False, "series", "haalman"),
        _spec("amigo-pi", rules.amigo_pi, "fopdt", True, "ideal", "amigo"),
        _spec("amigo-pid", rules.amigo_pid, "fopdt", True, "ideal", "amigo"),
        _spec("simc-pi", rules.simc_pi, "fopdt", True, "ideal", "simc"),
        _spec("simc-pid", rules.simc_pid, "sopdt", True, "series", "simc"),
        _spec("isimc-pi", rules.isimc_pi, "fopdt", True, "ideal", "isimc"),
        _spec("imc-pi", rules.imc_pi, "fopdt", True, "ideal", "imc"),
        _spec("imc-pid", rules.imc_pid, "fopdt", False, "ideal", "imc"),
    ]
}
"""Every rule by name; see :class:`PIDFormula`."""

"""Base class for the project's pythonfmu slaves (bundled into every FMU).

pythonfmu 0.7.0 writes no units, no min/max and no InitialUnknowns, so its
FMUs fail `fmpy validate` as built. `Slave` declares each variable with its
unit, description and bounds in one call (`add`), and extends `to_xml` with
UnitDefinitions, unit/min/max attributes, output dependencies and
InitialUnknowns. `declare` registers an FMU's variables from its one
declaration in ballmill.fmi.interface. It also provides full FMU-state save/restore: subclasses
return their internal state from `internal_state()` and take it back in
`restore_internal_state()`; pythonfmu alone would save registered variables
only and rollback would silently lose the integrator's state.

Everything here is FMI plumbing: no physics.
"""
from __future__ import annotations

import copy
from xml.etree.ElementTree import Element, SubElement

from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.enums import Fmi2Status
from pythonfmu.default_experiment import DefaultExperiment

from .interface import CRANK_KINEMATICS, LOG_CATEGORIES, UNITS, Interface  # noqa: F401 (re-exported)

_CAUSALITY = {"parameter": Fmi2Causality.parameter, "input": Fmi2Causality.input,
              "output": Fmi2Causality.output, "local": Fmi2Causality.local}
_TYPES = {float: Real, int: Integer, bool: Boolean}


class Slave(Fmi2Slave):
    """pythonfmu slave with units, bounds, dependencies and full state save."""

    log_categories = LOG_CATEGORIES

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self._meta: dict[str, dict] = {}
        self.author = "ballmill"
        self.license = "MIT"

    # -- declaration -------------------------------------------------------
    def declare(self, interface: Interface):
        """Register every variable of the FMU's one declaration (ballmill.fmi.interface),
        in its value-reference order, and its DefaultExperiment."""
        for v in interface.variables:
            self.add(v.name, v.causality, v.start, v.description, v.unit, v.min, v.max, v.depends,
                     variability=v.fmi_variability)
        self.set_default_experiment(*interface.default_experiment)

    def add(self, name: str, causality: str, start, description: str, unit: str | None = None,
            vmin: float | None = None, vmax: float | None = None, depends=None, variability=None):
        """Declare a variable and set its start value as an attribute.

        The Python type of ``start`` chooses the FMI type (float -> Real,
        int -> Integer, bool -> Boolean). ``depends`` lists the input names an
        output depends on during initialisation (InitialUnknowns); in
        continuous time the outputs here have no direct feedthrough.
        """
        kind = _TYPES[type(start)]
        if kind is Real and unit is None:
            raise ValueError(f"Real variable {name!r} needs a unit")
        if unit is not None and unit not in UNITS:
            raise ValueError(f"unit {unit!r} of {name!r} is not in UNITS")
        setattr(self, name, start)
        if variability is not None:
            variability = Fmi2Variability[variability]
        elif causality == "parameter":
            variability = Fmi2Variability.fixed
        elif kind is Real:
            variability = Fmi2Variability.continuous
        else:
            variability = Fmi2Variability.discrete
        self.register_variable(kind(name, causality=_CAUSALITY[causality], description=description,
                                    variability=variability))
        self._meta[name] = {"unit": unit, "min": vmin, "max": vmax, "depends": depends or ()}

    def choice(self, name: str, table: dict):
        """The meaning of an enumerated Integer parameter, or a ValueError naming
        the value and the allowed ones."""
        value = getattr(self, name)
        if value not in table:
            raise ValueError(f"{name} must be one of {sorted(table)} "
                             f"({', '.join(f'{k} = {v}' for k, v in table.items())}), got {value!r}")
        return table[value]

    def set_default_experiment(self, start: float, stop: float, step: float, tolerance: float | None = None):
        self.default_experiment = DefaultExperiment(start, stop, step, tolerance)

    # -- model description ---------------------------------------------------
    def to_xml(self, model_options=dict()) -> Element:  # noqa: B006 - pythonfmu's signature
        root = super().to_xml(model_options)
        used = sorted({m["unit"] for m in self._meta.values() if m["unit"]})
        units = Element("UnitDefinitions")
        for u in used:
            spec = dict(UNITS[u])
            factor = spec.pop("factor", None)
            unit_el = SubElement(units, "Unit", name=u)
            attrs = {k: str(v) for k, v in spec.items()}
            if factor is not None:
                attrs["factor"] = repr(factor)
            SubElement(unit_el, "BaseUnit", attrs)
        # schema order: CoSimulation, UnitDefinitions, TypeDefinitions, LogCategories, ...
        root.insert(list(root).index(root.find("CoSimulation")) + 1, units)

        index = {}
        for i, sv in enumerate(root.find("ModelVariables")):
            name = sv.get("name")
            index[name] = i + 1
            meta = self._meta.get(name)
            if not meta:
                continue
            typed = sv[0]
            if meta["unit"]:
                typed.set("unit", meta["unit"])
            for key in ("min", "max"):
                if meta[key] is not None:
                    v = meta[key]
                    typed.set(key, str(v) if isinstance(v, int) and sv.find("Integer") is not None
                              else repr(float(v)))
        structure = root.find("ModelStructure")
        outputs = structure.find("Outputs")
        init = SubElement(structure, "InitialUnknowns")
        if outputs is not None:
            for unknown in outputs:
                name = root.find("ModelVariables")[int(unknown.get("index")) - 1].get("name")
                unknown.set("dependencies", "")  # outputs at t_k come from the state only
                deps = " ".join(str(index[d]) for d in self._meta.get(name, {}).get("depends", ()))
                SubElement(init, "Unknown", index=unknown.get("index"), dependencies=deps)
        if not len(init):
            structure.remove(init)
        return root

    # -- initialisation ----------------------------------------------------
    _initialising = False

    def initialise(self) -> None:
        """Subclasses: build the model from the parameters and publish the
        outputs at the start time from the current inputs. Called at the exit
        of initialisation mode and on every read during it, so that a master
        that iterates over connected FMUs in initialisation mode (libcosim,
        ballmill's runner) sees outputs consistent with the inputs it set."""

    def enter_initialization_mode(self):
        self._initialising = True

    def exit_initialization_mode(self):
        self._initialising = False
        self.initialise()

    def get_real(self, vrs):
        if self._initialising:
            self.initialise()
        return super().get_real(vrs)

    def get_boolean(self, vrs):
        if self._initialising:
            self.initialise()
        return super().get_boolean(vrs)

    # -- state save/restore ------------------------------------------------
    def internal_state(self) -> dict:
        """Subclasses: everything beyond the registered variables, as plain data."""
        return {}

    def restore_internal_state(self, state: dict) -> None:
        """Subclasses: take back what `internal_state` returned."""

    def _get_fmu_state(self):
        state = super()._get_fmu_state()
        state["__internal__"] = copy.deepcopy(self.internal_state())
        return state

    def _set_fmu_state(self, state):
        state = dict(state)
        internal = state.pop("__internal__", None)
        super()._set_fmu_state(state)
        if internal is not None:
            self.restore_internal_state(copy.deepcopy(internal))

    # -- logging helpers ---------------------------------------------------
    def log(self, msg, status=Fmi2Status.ok, category=None, debug=None):
        # pythonfmu hands the message to the FMI logger as a printf format string
        # (cppfmu's Logger::Log): a literal '%' must travel as '%%'
        super().log(str(msg).replace("%", "%%"), status, category)

    def warn(self, msg: str):
        self.log(msg, Fmi2Status.warning)

    def error(self, msg: str):
        self.log(msg, Fmi2Status.error)

    def discard(self, msg: str) -> bool:
        """Log why a step is refused and return False (fmi2Discard)."""
        self.log(msg, Fmi2Status.discard)
        return False


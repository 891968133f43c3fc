"""The plant FMU's variables: the one source of modelDescription.xml and plant_vars.h.

Every real variable of the FMU, in value-reference order. The C code keeps
all of them in one array indexed by value reference, so a variable added here
appears in the XML and in C at the same reference; they cannot drift.
Physical constants and defaults are Appendix A of the paper (docs/model.md).
The same variables make the FMI 2.0 and the FMI 3.0 description.
"""
import hashlib
import uuid

MODEL_NAME = "hybridsim_plant"
DESCRIPTION = ("Raibert & Craig (1981) two-joint arm with stick-slip friction, hand on a wrist force "
               "sensor and a unilateral reaction surface (eqs 5-11, docs/model.md)")

# (name, causality, variability, start, unit, description)
P, I, O, L = "parameter", "input", "output", "local"
VARIABLES = [
    # inputs
    ("tau[1]", I, "continuous", 0.0, "N.m", "joint 1 actuator torque"),
    ("tau[2]", I, "continuous", 0.0, "N", "joint 2 actuator force"),
    ("x_surface", I, "continuous", 0.5, "m", "surface position along C-X"),
    ("v_surface", I, "continuous", 0.0, "m/s", "surface velocity along C-X"),
    # outputs
    ("q[1]", O, "continuous", None, "rad", "joint 1 angle"),
    ("q[2]", O, "continuous", None, "m", "joint 2 extension"),
    ("qd[1]", O, "continuous", None, "rad/s", "joint 1 rate"),
    ("qd[2]", O, "continuous", None, "m/s", "joint 2 rate"),
    ("F[1]", O, "continuous", None, "N", "sensed wrist force -Kw w, hand frame axis 1"),
    ("F[2]", O, "continuous", None, "N", "sensed wrist force -Kw w, hand frame axis 2"),
    ("x_hand[1]", O, "continuous", None, "m", "hand position C-X"),
    ("x_hand[2]", O, "continuous", None, "m", "hand position C-Y"),
    ("fx", O, "continuous", None, "N", "contact force of the surface"),
    ("contact", O, "discrete", None, "1", "true in contact"),
    # event indicators (FMI 3.0 names them by variable): slide <-> stick per joint, contact
    ("indicator[1]", L, "continuous", None, "rad/s", "|q1'| - stick_band"),
    ("indicator[2]", L, "continuous", None, "m/s", "|q2'| - stick_band"),
    ("indicator[3]", L, "continuous", None, "m", "penetration of the hand into the surface"),
    # parameters
    ("Kw", P, "fixed", 8.0e5, "N/m", "wrist stiffness"),
    ("Kr", P, "fixed", 9.0e5, "N/m", "surface stiffness"),
    ("M2", P, "fixed", 6.68, "kg", "link 2 mass"),
    ("M3", P, "fixed", 0.58, "kg", "hand mass"),
    ("I1_0", P, "fixed", 3.98, "kg.m2", "I1(q2) = I1_0 + I1_1 q2 + I1_2 q2^2"),
    ("I1_1", P, "fixed", -5.25, "kg.m", "I1 coefficient of q2"),
    ("I1_2", P, "fixed", 6.47, "kg", "I1 coefficient of q2^2"),
    ("l", P, "fixed", 0.153, "m", "link offset"),
    ("tau_c[1]", P, "fixed", 5.0, "N.m", "Coulomb friction joint 1"),
    ("tau_c[2]", P, "fixed", 3.5, "N", "Coulomb friction joint 2"),
    ("tau_s[1]", P, "fixed", 5.75, "N.m", "static friction joint 1"),
    ("tau_s[2]", P, "fixed", 4.6, "N", "static friction joint 2"),
    ("friction", P, "fixed", 1.0, "1", "stick-slip friction on"),
    ("stick_band", P, "fixed", 1e-4, "1", "Karnopp capture band on joint speeds (rad/s, m/s)"),
    ("stick_time", P, "fixed", 1e-3, "s", "time constant bringing a stuck joint to rest"),
    ("stribeck", P, "fixed", 0.0, "1", "Stribeck sliding friction (else Karnopp's constant tau_c)"),
    ("stribeck_velocity[1]", P, "fixed", 1e-3, "rad/s", "speed scale of the static-to-Coulomb decay, joint 1"),
    ("stribeck_velocity[2]", P, "fixed", 1e-3, "m/s", "speed scale of the static-to-Coulomb decay, joint 2"),
    ("b[1]", P, "fixed", 0.0, "N.m.s/rad", "joint 1 viscous damping"),
    ("b[2]", P, "fixed", 0.0, "N.s/m", "joint 2 viscous damping"),
    ("bw", P, "fixed", 0.0, "N.s/m", "wrist damping"),
    ("br", P, "fixed", 0.0, "N.s/m", "surface contact damping"),
    ("unilateral", P, "fixed", 1.0, "1", "the surface only pushes"),
    ("endpoint0[1]", P, "fixed", 0.5 + 10.0 * (1.0 / 9.0e5 + 1.0 / 8.0e5), "m",
     "initial arm endpoint C-X (inverse kinematics), when balance = 0"),
    ("endpoint0[2]", P, "fixed", 0.0, "m", "initial arm endpoint C-Y"),
    ("preload", P, "fixed", 10.0, "N", "initial contact force the hand balances along C-X"),
    ("balance", P, "fixed", 0.0, "1",
     "start in static balance: endpoint0[1] = surface_x0 + preload (1/Kr + 1/Kw), endpoint0[1] unused"),
    ("surface_x0", P, "fixed", 0.5, "m", "C-X of the surface at the start, when balance = 1"),
    ("max_substep", P, "fixed", 1e-4, "s", "co-simulation: largest internal RK4 step"),
    # continuous states and their derivatives (states first, derivatives after, same order)
    ("s.q1", L, "continuous", 0.0, "rad", "state q1"),
    ("s.q2", L, "continuous", 0.0, "m", "state q2"),
    ("s.qd1", L, "continuous", 0.0, "rad/s", "state q1'"),
    ("s.qd2", L, "continuous", 0.0, "m/s", "state q2'"),
    ("s.w1", L, "continuous", 0.0, "m", "state w1 (hand frame)"),
    ("s.w2", L, "continuous", 0.0, "m", "state w2"),
    ("s.wd1", L, "continuous", 0.0, "m/s", "state w1'"),
    ("s.wd2", L, "continuous", 0.0, "m/s", "state w2'"),
]
N_STATES = 8
STATE_NAMES = [v[0] for v in VARIABLES if v[0].startswith("s.")]
DERIVATIVES = [f"der({n})" for n in STATE_NAMES]
N_EVENT_INDICATORS = 3  # |q1'| - band, |q2'| - band, penetration
#: the variables that are Boolean (stored as 0/1 in the C array like the others)
BOOLEANS = {"friction", "unilateral", "contact", "stribeck"}
#: parameters that must be positive (min="0" in the description, and exitInitializationMode
#: refuses 0) and those that must not be negative (min="0")
POSITIVE = {"Kw", "Kr", "M2", "M3", "stick_band", "stick_time", "stribeck_velocity[1]", "stribeck_velocity[2]",
            "max_substep"}
NON_NEGATIVE = {"tau_c[1]", "tau_c[2]", "tau_s[1]", "tau_s[2]", "b[1]", "b[2]", "bw", "br", "l"}
#: SI base units of each unit the variables use (exponents of kg, m, s, rad)
_BASE = {"kg": {"kg": 1}, "m": {"m": 1}, "s": {"s": 1}, "rad": {"rad": 1}, "N": {"kg": 1, "m": 1, "s": -2}}
GENERATION_TOOL = "hybridsim 0.1.0 (fmus/plant_model.py)"
GENERATION_DATE = "2026-12-02T00:00:00Z"  # the date of this model's last change (reproducible builds)
VERSION = "3"  # the plant model's version: raised when its equations or variables change
TOLERANCE = 1e-6  # DefaultExperiment: a relative tolerance for a variable-step importer


def base_units(unit):
    """``{base: exponent}`` of a unit string such as 'N.m.s/rad' or 'kg.m2' (kg, m, s, rad)."""
    out = {}
    for k, part in enumerate(unit.split("/")):
        for token in filter(None, part.split(".")):
            name = token.rstrip("0123456789")
            power = int(token[len(name):] or 1) * (1 if k == 0 else -1)
            for base, e in _BASE[name].items():
                out[base] = out.get(base, 0) + e * power
    return {b: e for b, e in out.items() if e}


def _unit_definitions():
    """<UnitDefinitions> lines with a BaseUnit per unit (FMI 2.0 and 3.0 write them alike)."""
    units = sorted({v[4] for v in all_variables() if v[4] and v[4] != "1"})
    out = ["  <UnitDefinitions>"]
    for u in units:
        attrs = " ".join(f'{b}="{e}"' for b, e in sorted(base_units(u).items()))
        out.append(f'    <Unit name="{u}"><BaseUnit {attrs}/></Unit>')
    out.append("  </UnitDefinitions>")
    return out


def _min(name):
    return ' min="0"' if name in POSITIVE or name in NON_NEGATIVE else ""


def all_variables():
    """VARIABLES plus the derivative variables, with value references 0..n-1."""
    out = list(VARIABLES)
    units = {v[0]: v[4] for v in VARIABLES}
    for s, d in zip(STATE_NAMES, DERIVATIVES):
        out.append((d, L, "continuous", None, units[s] + "/s", f"derivative of {s}"))
    return out


def c_name(name):
    """C macro for a variable: 'tau_c[2]' -> VR_TAU_C_2, 'der(s.q1)' -> VR_DER_S_Q1."""
    out = name.replace("der(", "der_").replace(")", "").replace("[", "_").replace("]", "").replace(".", "_")
    return "VR_" + out.upper()


def guid():
    """The FMU's GUID / instantiation token: a hash of the variable list (it changes when they do)."""
    text = repr(all_variables()).encode()
    return "{" + str(uuid.UUID(hashlib.md5(text).hexdigest())) + "}"


def vars_header():
    """plant_vars.h: value references, count and start values."""
    vs = all_variables()
    lines = ["/* Generated by fmus/plant_model.py - do not edit. */",
             "#ifndef PLANT_VARS_H", "#define PLANT_VARS_H", "",
             f'#define MODEL_GUID "{guid()}"', f"#define N_VARS {len(vs)}",
             f"#define N_STATES {N_STATES}", f"#define N_EVENT_INDICATORS {N_EVENT_INDICATORS}", ""]
    for k, v in enumerate(vs):
        lines.append(f"#define {c_name(v[0])} {k}  /* {v[0]}: {v[5]} */")
    lines.append(f"#define VR_STATE0 {c_name(STATE_NAMES[0])}")
    lines.append(f"#define VR_TIME {len(vs)}  /* FMI 3.0: the independent variable */")
    lines.append(f"#define VR_DER0 {c_name(DERIVATIVES[0])}")
    starts = ", ".join(repr(float(v[3])) if v[3] is not None else "0.0" for v in vs)
    fixed = ", ".join("1" if v[2] == "fixed" else "0" for v in vs)
    boolean = ", ".join("1" if v[0] in BOOLEANS else "0" for v in vs)
    names = ", ".join(f'"{v[0]}"' for v in vs)
    kinds = ", ".join("2" if v[0] in POSITIVE else "1" if v[0] in NON_NEGATIVE else "0" for v in vs)
    lines += ["", f"static const double START_VALUES[N_VARS] = {{{starts}}};",
              f"static const char *const VAR_NAMES[N_VARS] = {{{names}}};",
              f"static const int MIN_KIND[N_VARS] = {{{kinds}}};  /* 2: must be positive, 1: not negative */",
              f"static const int FIXED[N_VARS] = {{{fixed}}};  /* set only before initialization ends */",
              f"static const int BOOLEAN[N_VARS] = {{{boolean}}};  /* fmi2Get/SetBoolean, not Real */",
              "", "#endif", ""]
    return "\n".join(lines)


#: the C files in sources/ an importer compiles to rebuild the binary (fmpy does, on any platform)
SOURCE_FILES = '    <SourceFiles><File name="plant.c"/></SourceFiles>'
#: per FMI version: the C files compiled into the binary
C_FILES = {2: ["plant.c"], 3: ["plant3.c"]}  # FMI 3.0: build_fmu adds the functions plant3.c does not define
EVENT_INDICATORS = ["indicator[1]", "indicator[2]", "indicator[3]"]


def model_description(fmi=2):
    """modelDescription.xml (Co-Simulation and Model Exchange) for FMI ``fmi`` (2 or 3)."""
    if fmi == 3:
        return model_description3()
    from xml.sax.saxutils import escape

    vs = all_variables()
    index = {v[0]: k + 1 for k, v in enumerate(vs)}  # 1-based ScalarVariable index
    out = ['<?xml version="1.0" encoding="UTF-8"?>',
           '<fmiModelDescription fmiVersion="2.0" modelName="%s" guid="%s"' % (MODEL_NAME, guid()),
           '  description="%s" generationTool="%s" variableNamingConvention="structured"'
           % (escape(DESCRIPTION), GENERATION_TOOL),
           f'  generationDateAndTime="{GENERATION_DATE}" version="{VERSION}"'
           f' numberOfEventIndicators="{N_EVENT_INDICATORS}">',
           f'  <ModelExchange modelIdentifier="{MODEL_NAME}" canGetAndSetFMUstate="true"'
           ' completedIntegratorStepNotNeeded="true">',
           SOURCE_FILES,
           "  </ModelExchange>",
           f'  <CoSimulation modelIdentifier="{MODEL_NAME}" canHandleVariableCommunicationStepSize="true"'
           ' canGetAndSetFMUstate="true">',
           SOURCE_FILES,
           "  </CoSimulation>"]
    out += _unit_definitions()
    out += [f'  <DefaultExperiment startTime="0" stopTime="4" tolerance="{TOLERANCE!r}" stepSize="0.016666666666666666"/>',
            "  <ModelVariables>"]
    for k, (name, caus, var, start, unit, desc) in enumerate(vs):
        attrs = f'name="{escape(name)}" valueReference="{k}" description="{escape(desc)}" causality="{caus}" variability="{var}"'
        real = f'unit="{escape(unit)}"' if unit and unit != "1" else ""
        if name.startswith("der("):
            real += f' derivative="{index[name[4:-1]]}"'
        if caus == "output":
            attrs += ' initial="calculated"'
        elif caus == "local":
            attrs += ' initial="calculated"' if name.startswith("s.") or name.startswith("der(") else ""
        if name in BOOLEANS:
            b = f' start="{"true" if start else "false"}"' if start is not None and caus == "parameter" else ""
            out.append(f"    <ScalarVariable {attrs}><Boolean{b}/></ScalarVariable>")
            continue
        if start is not None and caus in ("input", "parameter"):
            real += f' start="{start!r}"'
        real += _min(name)
        out.append(f"    <ScalarVariable {attrs}><Real {real.strip()}/></ScalarVariable>")
    out.append("  </ModelVariables>")
    out.append("  <ModelStructure>")
    out.append("    <Outputs>")
    states = " ".join(str(index[n]) for n in STATE_NAMES)
    surface = f"{index['x_surface']} {index['v_surface']}"
    for v in vs:  # outputs depend on the states; the contact force also on the surface input
        if v[1] == "output":
            deps = f"{states} {surface}" if v[0] in ("fx", "contact") else states
            out.append(f'      <Unknown index="{index[v[0]]}" dependencies="{deps}"/>')
    out.append("    </Outputs>")
    out.append("    <Derivatives>")
    out += [f'      <Unknown index="{index[d]}"/>' for d in DERIVATIVES]
    out.append("    </Derivatives>")
    out.append("    <InitialUnknowns>")
    initial = [v[0] for v in vs if v[1] == "output"] + STATE_NAMES + DERIVATIVES
    out += [f'      <Unknown index="{index[n]}"/>' for n in sorted(initial, key=index.get)]
    out.append("    </InitialUnknowns>")
    out += ["  </ModelStructure>", "</fmiModelDescription>", ""]
    return "\n".join(out)


def model_description3():
    """modelDescription.xml for FMI 3.0 (Co-Simulation and Model Exchange, the same variables).

    Its sources are listed in ``sources/buildDescription.xml`` (:func:`build_description`).
    """
    from xml.sax.saxutils import escape

    vs = all_variables()
    vr = {v[0]: k for k, v in enumerate(vs)}
    out = ['<?xml version="1.0" encoding="UTF-8"?>',
           f'<fmiModelDescription fmiVersion="3.0" modelName="{MODEL_NAME}" instantiationToken="{guid()}"',
           f'  description="{escape(DESCRIPTION)}" generationTool="{GENERATION_TOOL}"'
           f' generationDateAndTime="{GENERATION_DATE}" version="{VERSION}" variableNamingConvention="structured">',
           f'  <ModelExchange modelIdentifier="{MODEL_NAME}" canGetAndSetFMUState="true"/>',
           f'  <CoSimulation modelIdentifier="{MODEL_NAME}" canHandleVariableCommunicationStepSize="true"'
           ' canGetAndSetFMUState="true" canReturnEarlyAfterIntermediateUpdate="false"/>']
    out += _unit_definitions()
    out += [f'  <DefaultExperiment startTime="0" stopTime="4" tolerance="{TOLERANCE!r}" stepSize="0.016666666666666666"/>',
            "  <ModelVariables>",
            f'    <Float64 name="time" valueReference="{len(vs)}" causality="independent" variability="continuous"/>']
    for k, (name, caus, var, start, unit, desc) in enumerate(vs):
        attrs = f'name="{escape(name)}" valueReference="{k}" description="{escape(desc)}" causality="{caus}" variability="{var}"'
        if caus == "output" or name.startswith(("s.", "der(")):
            attrs += ' initial="calculated"'
        if name in BOOLEANS:
            b = f' start="{"true" if start else "false"}"' if start is not None and caus == "parameter" else ""
            out.append(f"    <Boolean {attrs}{b}/>")
            continue
        if unit and unit != "1":
            attrs += f' unit="{escape(unit)}"'
        if name.startswith("der("):
            attrs += f' derivative="{vr[name[4:-1]]}"'
        if start is not None and caus in ("input", "parameter"):
            attrs += f' start="{start!r}"'
        attrs += _min(name)
        out.append(f"    <Float64 {attrs}/>")
    out += ["  </ModelVariables>", "  <ModelStructure>"]
    states = " ".join(str(vr[n]) for n in STATE_NAMES)
    surface = f"{vr['x_surface']} {vr['v_surface']}"
    for v in vs:
        if v[1] == "output":
            deps = f"{states} {surface}" if v[0] in ("fx", "contact") else states
            out.append(f'    <Output valueReference="{vr[v[0]]}" dependencies="{deps}"/>')
    out += [f'    <ContinuousStateDerivative valueReference="{vr[d]}"/>' for d in DERIVATIVES]
    initial = [v[0] for v in vs if v[1] == "output"] + STATE_NAMES + DERIVATIVES
    out += [f'    <InitialUnknown valueReference="{vr[n]}"/>' for n in sorted(initial, key=vr.get)]
    out += [f'    <EventIndicator valueReference="{vr[n]}"/>' for n in EVENT_INDICATORS]
    out += ["  </ModelStructure>", "</fmiModelDescription>", ""]
    return "\n".join(out)


def build_description():
    """sources/buildDescription.xml (FMI 3.0): the C files an importer compiles to rebuild the binary."""
    from hybridsim.fmi.build import UNSUPPORTED_C

    files = "\n".join(f'      <SourceFile name="{f}"/>' for f in C_FILES[3] + [UNSUPPORTED_C])
    return ('<?xml version="1.0" encoding="UTF-8"?>\n<fmiBuildDescription fmiVersion="3.0">\n'
            f'  <BuildConfiguration modelIdentifier="{MODEL_NAME}">\n    <SourceFileSet language="C99">\n'
            f"{files}\n    </SourceFileSet>\n  </BuildConfiguration>\n</fmiBuildDescription>\n")

"""Units and descriptions of the ``phase-cancellation`` dataset's columns.

Every column of the ``samples`` and ``cells`` tables gets a description that says what it
is, how it was computed and in which unit; the names follow a pattern (quantity, antenna,
technique), so the descriptions are assembled from the same parts. Antennas: SA1 is the
receive-only path P1, SA2 the full ST path P2 (the single-antenna ST uses SA2), "combined"
the RF sum SA1 + SA2 (simple combination). Techniques (AURIS dissertation R3-5, §5):
single (SA2 alone), combination (chain on SA1 + SA2), selection (Algorithm 1: SA2, else
SA1), stamp (ASK-PSK stamp chooses the path).
"""

from __future__ import annotations

ANTENNAS = {
    "sa1": "SA1 (receive-only path P1)",
    "sa2": "SA2 (full ST path P2; the single-antenna ST)",
    "combined": "the RF sum SA1 + SA2 (simple combination)",
}
TECHNIQUES = {
    "single": "single antenna (SA2 alone)",
    "combination": "simple combination (one chain on SA1 + SA2)",
    "selection": "receiving-path selection (Algorithm 1: SA2, else SA1)",
    "stamp": "ASK-PSK stamp (the stamp's ASK symbol picks SA2 or SA1)",
}
_VOLTS = ("antenna-level amplitude sqrt(2R)|phasor| at R = 50 ohm of the narrowband phasor at the "
          "reference sample (the reader's CW after its command)")

FIXED: dict[str, tuple[str, str]] = {
    "cell": ("1", "index of the cell (tag position) in geometry.tag_x_m, 0-based"),
    "repetition": ("1", "repetition of the cell: new ST positions, reader/tag draws and channel"),
    "tag_x_m": ("m", "tag x position of the cell (reader antenna at the origin, boresight +x)"),
    "st_x_m": ("m", "x of the ST centre, uniform in a disc of geometry.disc_radius_m around the tag"),
    "st_y_m": ("m", "y of the ST centre, uniform in a disc of geometry.disc_radius_m around the tag"),
    "orientation_rad": ("rad", "azimuth of the ST's antenna pair axis SA1->SA2, uniform in [-pi, pi)"),
    "tag_replied": ("1", "the tag powered up, decoded the reader's Query and replied its RN16 in this "
                         "cell and repetition (false: no backscatter to detect)"),
    "narrowband_error": ("1", "largest relative RMS envelope error of applying the ST links narrowband "
                              "(rfsim.protocols.engine.narrowband_rms_error, must stay <= NARROWBAND_TOLERANCE)"),
    "tag_available_power_w": ("W", "CW power available at the tag antenna port during the Query"),
    "tag_chip_power_w": ("W", "power absorbed by the tag chip (available power x power transmission "
                              "coefficient of the chip's unmodulated state)"),
    "sync_sa2_v": ("V", "detector-output envelope difference at SA2 with the CW synchronised to the "
                        "backscatter: max over the CW phase phi of ||c e^{j phi} + b1| - |c e^{j phi} + b2|| "
                        "(= |b1 - b2| when the CW dominates) through the detector law: the detectability "
                        "condition (R3-5, rfsim.devices.st_analytic.synchronised_difference)"),
    "rerad_b_abs": ("1", "|r_B| = |A_s - Gamma_B|, magnitude of the tag's re-radiated modulating state"),
    "rerad_a_abs": ("1", "|r_A| = |A_s - Gamma_A|, magnitude of the tag's re-radiated absorbing state"),
    "near_field": ("1", "an ST antenna lies within lambda/(2 pi) = 5.2 cm of the tag (reactive near "
                        "field, where the far-field links do not hold): excluded from the probabilities"),
    "n_near_field": ("1", "ST samples of the cell with an antenna within lambda/(2 pi) of the tag (excluded)"),
    "detectable": ("1", "sync_sa2_v above the comparator threshold st.threshold_v: a single-antenna ST "
                        "would see the tag without phase cancellation"),
    "stamp_use_p1": ("1", "the ASK stamp symbol was '-' on SA2, so the stamp technique decoded on SA1"),
    "n_samples": ("1", "ST samples of the cell over all repetitions outside the near field (the trials "
                       "of each probability)"),
    "tag_replied_fraction": ("1", "fraction of the cell's repetitions in which the tag replied its RN16 "
                                  "(0: the tag does not run at this distance)"),
    "detectable_fraction": ("1", "fraction of the cell's ST samples that are detectable"),
    "median_a_t1_over_a_r_sa2": ("1", "median over the cell's samples of A_T1/A_R at SA2 (Table 3.1/3.2 "
                                      "quote 0.54-0.99 in cell 1)"),
}


def units(key: str) -> str:
    """Unit of column ``key`` (from :data:`FIXED`, else from the name's suffix)."""
    if key in FIXED:
        return FIXED[key][0]
    for suffix, unit in (("_v", "V"), ("_m", "m"), ("_rad", "rad"), ("_w", "W")):
        if key.endswith(suffix):
            return unit
    return "1"


#: (name prefix, description template) of the per-antenna columns; {ant} names the antenna.
ANTENNA_COLUMNS = (
    ("a_r_", "A_R, amplitude of the reader's CW at {ant}: " + _VOLTS),
    ("a_t1_", "A_T1, backscatter amplitude at {ant} in the tag's modulating state (re-radiated A_s - Gamma_B "
              "times the incident field): " + _VOLTS),
    ("a_t2_", "A_T2, backscatter amplitude at {ant} in the tag's absorbing state (re-radiated A_s - Gamma_A "
              "times the incident field): " + _VOLTS),
    ("theta_", "theta, phase of the backscatter (state 1) relative to the reader's CW at {ant}, (-pi, pi]"),
    ("diff_", "sample-level envelope difference |A(+1) - A(-1)| at the detector output of {ant}: mean detector "
              "level in the tag's two states over the RN16 reply (0 when the tag did not reply)"),
    ("closed_diff_", "closed-form envelope difference |A1 - A2| (Eq. 3.4, Eq. 3.21 for the sum) at {ant} from "
                     "the measured phasors through the detector law (detector.law; |f(|c + b1|) - f(|c + b2|)|)"),
)
#: (name prefix, description template) of the per-technique columns; {tech} names the technique.
TECHNIQUE_COLUMNS = (
    ("detected_", "the ST decoded the tag's RN16 exactly with {tech} (sample-level receive chain)"),
    ("closed_cancelled_", "phase cancellation predicted by the closed forms (Eq. 3.4/3.21, R3-5) for {tech}: "
                          "detectable, but the technique's envelope difference is below the threshold"),
    ("cancelled_", "phase cancellation with {tech}: detectable and not detected (sample level)"),
    ("p_", "probability of phase cancellation with {tech} in the cell: cancelled samples / n_samples (R3-5)"),
    ("ci_lo_", "lower bound of the Clopper-Pearson 95 % interval of p_{key} (n_samples trials)"),
    ("ci_hi_", "upper bound of the Clopper-Pearson 95 % interval of p_{key} (n_samples trials)"),
)


def describe(key: str) -> str:
    """Description of column ``key`` of the samples or cells table (ValueError if unknown)."""
    if key in FIXED:
        return FIXED[key][1]
    ant = next((a for a in ANTENNAS if f"_{a}_" in f"_{key}_"), None)
    tech = next((t for t in TECHNIQUES if key.endswith(f"_{t}")), None)
    if ant:
        for prefix, template in ANTENNA_COLUMNS:
            if key.startswith(prefix):
                return template.format(ant=ANTENNAS[ant])
    if tech:
        for prefix, template in TECHNIQUE_COLUMNS:
            if key.startswith(prefix):
                return template.format(tech=TECHNIQUES[tech], key=tech)
    if key.startswith("median_") and key.endswith("_sa2_source_v"):
        name = {"a_r": "A_R", "a_t1": "A_T1", "a_t2": "A_T2"}[key[len("median_"):-len("_sa2_source_v")]]
        return (f"median over the cell's samples of {name} at SA2 in the source's voltage unit (peak sqrt(2P) "
                f"across 1 ohm, the unit of Tables 3.1/3.2)")
    if ant and key.endswith(("_x_m", "_y_m")):
        return f"{key[-3]} position of the antenna {ANTENNAS[ant]} (ST centre +- half the antenna spacing)"
    raise ValueError(f"phase-cancellation column {key!r} has no description")


__all__ = ["ANTENNAS", "TECHNIQUES", "FIXED", "ANTENNA_COLUMNS", "TECHNIQUE_COLUMNS", "units", "describe"]

"""The documents rfsim's models come from: full references and the short names figures use.

Figure titles and dataset attributes cite a source by its short name plus the figure,
table or equation number *in that document* (e.g. "AURIS dissertation Fig. 3.16"), and the
README's "References" section lists the full entries below, so every number can be looked up.
Where a document's title page is not available, the entry says what is known and how.
"""

from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class Reference:
    """One source document.

    Parameters
    ----------
    key : str
        Key of the entry in :data:`REFERENCES`.
    short : str
        Short name for figure captions.
    full : str
        The bibliographic entry.
    """

    key: str
    short: str
    full: str


REFERENCES: dict[str, Reference] = {r.key: r for r in (
    Reference(
        "auris", "AURIS dissertation (Wang, uOttawa)",
        "J. Wang, PhD dissertation on proximity-based indoor localization with tag-to-tag backscatter "
        "communication in the augmented UHF RFID system (AURIS) — phase cancellation at sense-a-tags, "
        "dual-antenna techniques, detection-probability models (RTS/TS), PF-AA and SQLAM — University of "
        "Ottawa, c. 2016. The available text has no title page: the subject is taken from its abstract, the "
        "author and institution from the credits of its simulator PASS (\"Jing Wang, Identigo Lab, uOttawa\"), "
        "the year from its text and PASS's history (2014–2016)."),
    Reference(
        "himr", "HIMR dissertation (Akbar, Georgia Tech 2016)",
        "M. B. Akbar, *Hybrid Inertial Microwave Reflectometry for mm-Scale Tracking in RFID Systems*, PhD "
        "dissertation, School of Electrical and Computer Engineering, Georgia Institute of Technology, "
        "Atlanta, GA, USA, August 2016 (advisor G. D. Durgin)."),
    Reference(
        "sarkka", "Särkkä et al. 2012",
        "S. Särkkä, V. V. Viikari, M. Huusko and K. Jaakkola, \"Phase-Based UHF RFID Tracking With Nonlinear "
        "Kalman Filtering and Smoothing,\" *IEEE Sensors Journal*, vol. 12, 2012 (published online "
        "8 August 2011), doi:10.1109/JSEN.2011.2164062."),
    Reference(
        "ozkaya", "Özkaya, METU 2011",
        "B. Özkaya, *Application, Comparison, and Improvement of Known Received Signal Strength Indication "
        "(RSSI) Based Indoor Localization and Tracking Methods Using Active RFID Devices*, MSc thesis, "
        "Electrical and Electronics Engineering, Middle East Technical University, Ankara, February 2011."),
    Reference(
        "geng", "Geng dissertation (Stony Brook 2015)",
        "L. Geng, *Indoor Localization and Tracking Using Binary Information*, PhD dissertation, Electrical "
        "Engineering, Stony Brook University, Stony Brook, NY, USA, August 2015 (advisor M. F. Bugallo)."),
    Reference(
        "gen2", "EPC Gen2",
        "EPCglobal, *EPC Radio-Frequency Identity Protocols Class-1 Generation-2 UHF RFID Protocol for "
        "Communications at 860 MHz – 960 MHz*, version 1.2.0, 2008; its successors GS1 *EPC UHF Gen2 Air "
        "Interface Protocol* v2.x and ISO/IEC 18000-63 keep the values used here (cited by section name)."),
    Reference(
        "pass", "PASS/PARIS",
        "D. Arnitz, *PARIS — Position Aware RFID Systems simulation framework* (MATLAB, TU Graz / NXP / Duke, "
        "beta 3.0, 2012, GPLv3) and J. Wang, *PASS — Proximity-detection-based Augmented RFID System "
        "Simulator* (MATLAB, Identigo Lab, University of Ottawa, beta 3.1, 2014–2016, GPLv3, "
        "github.com/wacoder/PASS)."),
)}


def cite(key: str, where: str = "") -> str:
    """Caption text for ``where`` in document ``key``: "AURIS … Fig. 3.16".

    Parameters
    ----------
    key : str
        Key of :data:`REFERENCES`.
    where : str
        Place in the document, e.g. ``"Fig. 3.16"``.

    Returns
    -------
    str
        The short citation followed by ``where``.
    """
    short = REFERENCES[key].short
    return f"{short} {where}".strip()


__all__ = ["Reference", "REFERENCES", "cite"]

"""Markdown tables of the classifier protocol's ``results.json`` (experiments/eval_protocol.py), and
their insertion into experiments/RESULTS.md between two marker comments (the prose around them is
hand-written and kept)."""
from __future__ import annotations

from pathlib import Path

KINDS = ("logreg", "rf", "gb")
#: the CNN variant that reads the record level in m/s^2 (bound to the sensor path), shown beside the chosen CNN
CALIBRATED = "tsa_level"


def _pct(v) -> str:
    return "-" if v is None else f"{100 * v:.1f}"


def _row(label: str, s: dict) -> str:
    mae = s.get("severity_mae")
    mae = "-" if mae is None else f"{mae:.3f}"
    return (f"| {label} | {_pct(s.get('accuracy'))} | {_pct(s.get('macro_f1'))} | {_pct(s.get('teeth_accuracy'))} | "
            f"{_pct(s.get('teeth_macro_f1'))} | {mae} |")


HEAD = ("| model | severity acc. % | severity macro-F1 % | teeth acc. % | teeth macro-F1 % | severity MAE |\n"
        "|---|---|---|---|---|---|")


def _protocol_rows(r: dict, choice: str, label: str) -> list[str]:
    b = r["baselines"]
    best = b.get("best") or max(KINDS, key=lambda k: b[k]["test"]["accuracy"])
    rows = [_row(f"{label}: CNN ({choice})", r["cnn"][choice]["test"])]
    if CALIBRATED in r["cnn"] and CALIBRATED != choice:
        rows.append(_row(f"{label}: CNN reading the level in m/s^2 ({CALIBRATED})", r["cnn"][CALIBRATED]["test"]))
    return rows + [_row(f"{label}: best baseline ({best})", b[best]["test"])]


def results_tables(res: dict) -> str:
    """Markdown tables of ``results.json`` (inserted into RESULTS.md)."""
    out = []
    ind = res.get("in_domain")
    choice = ind["cnn_choice"] if ind else "tsa"
    if ind:
        out += ["### Headline: every protocol, the CNN and the best baseline", "", HEAD]
        out += _protocol_rows(ind, choice, "in-domain (default: many rigs)")
        if "rig" in res:
            rg = res["rig"]
            out += _protocol_rows(rg, rg["cnn_choice"], "in-domain (one rig)")
            for split, r in rg.get("cross_condition", {}).items():
                out += _protocol_rows(r, rg["cnn_choice"], f"cross-condition, one rig ({split}: {r['rule']})")
        if "randomised" in res:
            rr = res["randomised"]
            ch = choice if choice in rr["cnn"] else rr["cnn_choice"]
            out += _protocol_rows(rr, ch, "in-domain (randomised sweep)")
        for split, r in res.get("cross_condition", {}).items():
            out += _protocol_rows(r, choice, f"cross-condition ({split}: {r['rule']})")
        if "cross_physics" in res:
            out += _protocol_rows(res["cross_physics"], choice, "cross-physics (no path -> path)")
        if "real" in res and "cnn" in res["real"]:
            rl = res["real"]
            for ch in ("a1", "a2", "a3", "a4"):
                out.append(f"| real data, channel {ch}: CNN (mesh_order, binary) | {_pct(rl['cnn'][ch]['accuracy'])} | "
                           f"{_pct(rl['cnn'][ch]['macro_f1'])} | n/a | n/a | n/a |")
                out.append(f"| real data, channel {ch}: logreg on mesh-order spectrum | "
                           f"{_pct(rl['logreg_mesh_order'][ch]['accuracy'])} | - | n/a | n/a | n/a |")
        out += ["", f"CNN variant chosen on the validation split: **{choice}** (among the variants not bound to "
                f"the sensor calibration; `{CALIBRATED}` also reads the record level in m/s^2 and is shown beside "
                "it); best baseline chosen on an internal 80/20 split of the training data. Accuracy and macro-F1 "
                "in %, severity MAE in pitted fraction of the flank.", ""]
        out += ["### In-domain (default dataset): every input representation and baseline", "",
                f"{ind['n_train']} training records (of which 20 % validation for early stopping), "
                f"{ind['n_test']} test records.", "",
                "| model | val. acc. % | val. teeth acc. % | test severity acc. % | test macro-F1 % | test teeth acc. % | "
                "test severity MAE | epochs | train s |", "|---|---|---|---|---|---|---|---|---|"]
        for rep, r in ind["cnn"].items():
            t = r["test"]
            out.append(f"| CNN {rep} | {_pct(r['val_accuracy'])} | {_pct(r['val_teeth_accuracy'])} | {_pct(t['accuracy'])} | "
                       f"{_pct(t['macro_f1'])} | {_pct(t.get('teeth_accuracy'))} | {t.get('severity_mae', 0):.3f} | "
                       f"{r['epochs']} | {r['train_seconds']} |")
        for kind in KINDS:
            t = ind["baselines"][kind]["test"]
            out.append(f"| {kind} (feature table) | - | - | {_pct(t['accuracy'])} | {_pct(t['macro_f1'])} | "
                       f"{_pct(t.get('teeth_accuracy'))} | {t.get('severity_mae', 0):.3f} | - | - |")
        out.append("")
    if "augmentation" in res:
        a = res["augmentation"]
        out += [f"### Augmentation ablation (CNN {choice}, default dataset, same split)", "", HEAD]
        if ind:
            out.append(_row("default (light: 25 % of records + noise at 20-40 dB, 0.2 % speed error)",
                            ind["cnn"][choice]["test"]))
        out.append(_row("none (no crop, gain, noise, speed error or polarity)", a["none"]["test"]))
        out.append(_row("strong (50 % + noise at 5-30 dB, 1 % speed error)", a["strong"]["test"]))
        out.append("")
    if "learning_curve" in res and ind:
        lc = res["learning_curve"]
        out += [f"### Learning curve (CNN {choice}, default dataset, same test split)", "",
                "| training records (incl. 20 % validation) | severity acc. % | teeth acc. % | severity MAE |",
                "|---|---|---|---|"]
        for f, r in sorted(lc.items(), key=lambda kv: float(kv[0])):
            out.append(f"| {r['n_train']} ({100 * float(f):.0f} %) | {_pct(r['test']['accuracy'])} | "
                       f"{_pct(r['test'].get('teeth_accuracy'))} | {r['test'].get('severity_mae', 0):.3f} |")
        t = ind["cnn"][choice]
        out += [f"| {t['n_train']} (100 %) | {_pct(t['test']['accuracy'])} | {_pct(t['test'].get('teeth_accuracy'))} | "
                f"{t['test'].get('severity_mae', 0):.3f} |", ""]
    if "ceiling" in res:
        c = res["ceiling"]
        out += ["### Severity identifiability check (default dataset, same split)", "",
                "| gradient boosting on | severity acc. % |", "|---|---|",
                f"| the feature table | {_pct(c['features'])} |",
                f"| the feature table + the true nuisance parameters of each record | "
                f"{_pct(c['features_and_true_nuisances'])} |", ""]
    sections = [("cross_condition", "Cross-condition")]
    for key, title in sections:
        for split, r in res.get(key, {}).items():
            out += [f"### {title}: {split} ({r['rule']}; {r['n_train']} train, {r['n_test']} test)", "", HEAD]
            out += [_row(f"CNN {rep}", v["test"]) for rep, v in r["cnn"].items()]
            out += [_row(kind, r["baselines"][kind]["test"]) for kind in KINDS] + [""]
    if "cross_physics" in res:
        r = res["cross_physics"]
        out += [f"### Cross-physics ({r['rule']}; {r['n_train']} train, {r['n_test']} test)", "", HEAD]
        out += [_row(f"CNN {rep}", v["test"]) for rep, v in r["cnn"].items()]
        out += [_row(kind, r["baselines"][kind]["test"]) for kind in KINDS] + [""]
    if "rig" in res:
        r = res["rig"]
        pp = r.get("augment", {}).get("path_probability", 0.0)
        aug = (f"; the CNNs train with the transmission-path augmentation in {pp:.0%} of the records".replace("%", " %")
               if pp else "")
        out += [f"### One rig (rig.toml): in-domain ({r['n_train']} train, {r['n_test']} test; variant chosen on "
                f"the validation split: **{r['cnn_choice']}**{aug})", "", HEAD]
        out += [_row(f"CNN {rep}", v["test"]) for rep, v in r["cnn"].items()]
        out += [_row(kind, r["baselines"][kind]["test"]) for kind in KINDS] + [""]
        for split, c in r.get("cross_condition", {}).items():
            out += [f"### One rig, cross-condition: {split} ({c['rule']}; {c['n_train']} train, {c['n_test']} test)",
                    "", HEAD]
            out += [_row(f"CNN {rep}", v["test"]) for rep, v in c["cnn"].items()]
            out += [_row(kind, c["baselines"][kind]["test"]) for kind in KINDS] + [""]
    if "randomised" in res:
        r = res["randomised"]
        out += [f"### In-domain on the randomised sweep ({r['n_train']} train, {r['n_test']} test)", "", HEAD]
        out += [_row(f"CNN {rep}", v["test"]) for rep, v in r["cnn"].items()]
        out += [_row(kind, r["baselines"][kind]["test"]) for kind in KINDS] + [""]
    if "real" in res and "cnn" in res["real"]:
        rl = res["real"]
        out += ["### Real data (SpectraQuest, healthy vs broken tooth; trained on synthetic healthy vs pitted)", "",
                f"{rl['n_records_per_channel']} records of 8192 samples per channel from {len(rl['files'])} files. "
                "Estimated mesh frequency per file (cycles/sample): "
                + ", ".join(f"{k} {v}" for k, v in rl["mesh_cps"].items()) + ".", "",
                "| channel | CNN acc. % | CNN macro-F1 % | CNN: fraction called damaged | logreg (mesh-order) acc. % | "
                "logreg: fraction called damaged | real-to-real (leave one load out) acc. % |",
                "|---|---|---|---|---|---|---|"]
        for ch in ("a1", "a2", "a3", "a4"):
            c, lg = rl["cnn"][ch], rl["logreg_mesh_order"][ch]
            out.append(f"| {ch} | {_pct(c['accuracy'])} | {_pct(c['macro_f1'])} | "
                       f"{_pct(rl['cnn_predicted_damaged_fraction'][ch])} | {_pct(lg['accuracy'])} | "
                       f"{_pct(lg['predicted_damaged_fraction'])} | {_pct(rl['real_to_real'][ch])} |")
        out.append("")
    return "\n".join(out) + "\n"


BEGIN, END = "<!-- tables:begin (written by experiments/eval_protocol.py) -->", "<!-- tables:end -->"


def insert_tables(path: Path, tables: str, markers: tuple[str, str] = (BEGIN, END)) -> None:
    """Replace the text between the two ``markers`` of ``path`` (append the markers if missing)."""
    begin, end = markers
    text = path.read_text() if path.is_file() else "# Classifier results\n\n"
    if begin in text and end in text:
        head, rest = text.split(begin, 1)
        tail = rest.split(end, 1)[1]
    else:
        head, tail = text + "\n", "\n"
    path.write_text(head + begin + "\n\n" + tables + "\n" + end + tail)

// The control panel: dataset list, named views, transfer function (preset or the curve editor), value window,
// shading and quality target. Controls write into the view and call `changed`; sync* write the view back into them.

import * as V from "./view.js";

const $ = (id) => document.getElementById(id);

/// `o`: {view, changed(phase), openDataset(name), curve: CurveEditor, save()}. Returns the panel's sync functions.
export function bindPanel(o) {
  const view = o.view;
  let range = null; // the open dataset's value range
  let presets = {}; // the server's presets by name: their points, drawn in the curve editor

  const tf = $("tf");
  const listPresets = (names) => {
    tf.replaceChildren(...[...names, "custom"].map((n) => new Option(n === "custom" ? "custom curve" : n, n)));
  };
  listPresets(V.PRESETS);
  /// The curve editor shows the chosen preset's own curve (dimmed: editing it starts a custom curve from it), or
  /// the custom curve.
  const showCurve = () => {
    const preset = view.tf !== "custom" && presets[view.tf];
    o.curve.set(preset ? preset : view.points, view.tf === "custom");
  };

  $("dataset").addEventListener("change", (e) => {
    $("dataset-note").hidden = true;
    o.openDataset(e.target.value);
  });
  $("save").addEventListener("click", () => o.save());
  for (const b of document.querySelectorAll("#views button")) {
    b.addEventListener("click", () => {
      const name = b.dataset.view;
      [view.az, view.el] = V.NAMED_VIEWS[name];
      Object.assign(view, { view: name, dist: null, pan: [0, 0] });
      o.changed("still");
    });
  }
  $("reset").addEventListener("click", () => {
    const d = V.defaultView(view.dataset);
    Object.assign(view, { view: null, az: d.az, el: d.el, dist: null, pan: [0, 0] });
    o.changed("still");
  });
  tf.addEventListener("change", () => {
    view.tf = tf.value;
    showCurve();
    o.changed("still");
  });
  const windowInput = () => {
    const [lo, hi] = [Number($("window-lo").value), Number($("window-hi").value)];
    if (Number.isFinite(lo) && Number.isFinite(hi) && hi > lo) {
      view.window = [lo, hi];
      o.changed("still");
    }
  };
  $("window-lo").addEventListener("change", windowInput);
  $("window-hi").addEventListener("change", windowInput);
  $("window-reset").addEventListener("click", () => {
    view.window = null;
    syncWindow();
    o.changed("still");
  });
  $("shading").addEventListener("change", (e) => {
    view.shading = e.target.checked;
    o.changed("still");
  });
  $("quality").addEventListener("change", (e) => {
    view.quality = e.target.value;
    $("quality-note").hidden = true;
    o.changed("still");
  });

  function syncWindow() {
    const w = view.window || range;
    $("window-lo").value = w ? String(Number(w[0].toPrecision(6))) : "";
    $("window-hi").value = w ? String(Number(w[1].toPrecision(6))) : "";
    if (range) {
      const step = (range[1] - range[0]) / 100 || 1;
      $("window-lo").step = $("window-hi").step = String(Number(step.toPrecision(2)));
    }
  }
  function syncTf() {
    if (![...tf.options].some((x) => x.value === view.tf)) tf.add(new Option(view.tf, view.tf));
    tf.value = view.tf;
    showCurve();
  }
  function syncView() {
    for (const b of document.querySelectorAll("#views button")) b.classList.toggle("on", b.dataset.view === view.view);
  }
  function syncAll() {
    syncTf();
    syncWindow();
    syncView();
    $("shading").checked = view.shading;
    const q = $("quality");
    if (view.quality && ![...q.options].some((x) => x.value === view.quality))
      q.add(new Option(view.quality, view.quality));
    q.value = view.quality;
  }

  return {
    syncAll,
    syncTf,
    syncView,
    /// The datasets, by name; `pacs` (the Stats' `pacs`, if any) labels a PACS's series by what they hold, grouped
    /// under their PACS: "MR T1 axial · Head study · 2026-12-04 · 316 images" (the series, its study, the patient
    /// where the server shows one, the study's date, the images).
    datasets(names, pacs = []) {
      const sel = $("dataset");
      const label = new Map();
      const groups = [];
      for (const p of pacs || []) {
        const group = document.createElement("optgroup");
        group.label = `PACS ${p.id}`;
        for (const s of p.series || []) {
          if (!names.includes(s.name)) continue;
          const date = /^\d{8}$/.test(s.study_date || "")
            ? `${s.study_date.slice(0, 4)}-${s.study_date.slice(4, 6)}-${s.study_date.slice(6)}`
            : "";
          const who = s.patient && s.patient.name ? s.patient.name.replace(/\^/g, " ") : "";
          // The series, then its study: what a radiologist picks by.
          const study = s.study_description && s.study_description !== s.description ? s.study_description : "";
          const parts = [`${s.modality || "?"} ${s.description || "series"}`.trim(), study, who, date];
          if (s.instances >= 0) parts.push(`${s.instances} images`);
          const option = new Option(parts.filter(Boolean).join(" · "), s.name);
          option.title = s.name;
          group.append(option);
          label.set(s.name, option);
        }
        if (group.children.length) groups.push(group);
      }
      sel.replaceChildren(...names.filter((n) => !label.has(n)).map((n) => new Option(n, n)), ...groups);
    },
    /// The server's presets ({name: points}): the list and the curves.
    presets(byName) {
      presets = byName;
      listPresets(Object.keys(byName));
      syncTf();
    },
    /// A note under the dataset list (empty: none).
    datasetNote(text) {
      $("dataset-note").textContent = text;
      $("dataset-note").hidden = !text;
    },
    opened(meta) {
      range = meta.value_range || null;
      $("dataset").value = view.dataset;
      syncAll();
    },
    qualityRefused(message) {
      const n = $("quality-note");
      n.textContent = `No quality target here: ${message}`;
      n.hidden = false;
      $("quality").value = "";
    },
  };
}

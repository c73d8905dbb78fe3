"use strict";
window.BO2Report = (function () {
  const data = JSON.parse(document.getElementById("report-data").textContent);
  const hdr = {};          // folder -> {variant: {w, h, rgb: Float32Array}} once decoded
  const waiting = {};      // folder -> callbacks waiting for hdr.js
  const scenes = [];       // per scene: {entry, el, variant, mode, visible, key}
  const view = document.getElementById("view");
  const exposure = document.getElementById("exposure");
  const exposureValue = document.getElementById("exposure-value");
  const MIN_WIDTH = 480;  // px: a smaller render is shown enlarged
  const MAGMA = "linear-gradient(90deg,#000004,#3b0f70,#8c2981,#de4968,#fe9f6d,#fcfdbf)";

  function el(tag, attrs, ...children) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) {
      if (k === "class") e.className = v; else if (k === "text") e.textContent = v;
      else e.setAttribute(k, v);
    }
    for (const c of children) if (c != null) e.append(c);
    return e;
  }
  const fmt = (v, d) => (v == null ? "\u2013" : Number(v).toFixed(d));
  const fmtSeconds = (s) => (s == null ? "\u2013" : s < 10 ? s.toFixed(2) : s.toFixed(1));
  function combined(entry, variant) {
    const v = entry.variants[variant] || Object.values(entry.variants)[0];
    return v.metrics.Combined;
  }

  // ---- header, notices
  document.getElementById("title").textContent = data.title;
  document.getElementById("meta").textContent =
    `${data.scenes.length} scene${data.scenes.length === 1 ? "" : "s"} \u00b7 ` +
    `${data.created} \u00b7 Blender ${data.blender_version}`;
  const notices = document.getElementById("notices");
  const failing = data.scenes.filter((s) => s.failing);
  if (data.fail_above != null) {
    notices.append(el("div", {class: "notice" + (failing.length ? " fail" : ""), id: "verdict",
      text: failing.length
        ? `${failing.length} of ${data.scenes.length} scenes above the mean FLIP limit ` +
          `${data.fail_above}: ${failing.map((s) => s.name).join(", ")}`
        : `All ${data.scenes.length} scenes at or below the mean FLIP limit ${data.fail_above}.`}));
  }
  if (data.flip) notices.append(el("div", {class: "notice", text: data.flip}));
  for (const f of data.failed || []) {
    notices.append(el("div", {class: "notice fail", text: `Not compared: ${f.name}: ${f.error}`}));
  }
  if (data.pending && data.pending.length) {
    notices.append(el("div", {class: "notice", text: "Not rendered (the report was stopped): " +
      data.pending.join(", ")}));
  }

  // ---- summary table
  const tbody = document.querySelector("#summary tbody");
  for (const s of data.scenes) {
    const m = combined(s, "bo2");
    const bo2s = (s.variants.bo2 || {}).seconds;
    const row = el("tr", {class: s.failing ? "failing" : "", "data-scene": s.folder});
    const values = {thumb: null, name: s.name, flip_ldr: m.flip_ldr, flip_hdr: m.flip_hdr,
      psnr_db: m.psnr_db, ssim: m.ssim, rmse: m.rmse, bo2_s: bo2s, cycles_s: s.cycles_seconds,
      speedup: bo2s && s.cycles_seconds ? s.cycles_seconds / bo2s : null};
    row.sortValues = values;
    const link = el("a", {href: "#scene-" + s.folder},
      el("img", {class: "thumb", src: s.cycles_pictures.thumbnail, alt: s.name}));
    row.append(el("td", {}, link), el("td", {class: "name text"}, el("a", {href: "#scene-" + s.folder, text: s.name})),
      el("td", {text: fmt(m.flip_ldr, 4)}), el("td", {text: fmt(m.flip_hdr, 4)}),
      el("td", {text: fmt(m.psnr_db, 2)}), el("td", {text: fmt(m.ssim, 3)}),
      el("td", {text: fmt(m.rmse, 4)}), el("td", {text: fmtSeconds(bo2s)}),
      el("td", {text: fmtSeconds(s.cycles_seconds)}),
      el("td", {text: values.speedup == null ? "\u2013" : values.speedup.toFixed(1) + "\u00d7"}));
    tbody.append(row);
  }
  sortable(document.getElementById("summary"));

  function sortable(table) {
    table.querySelectorAll("th").forEach((th) => th.addEventListener("click", () => {
      const key = th.dataset.key;
      const ascending = th.getAttribute("aria-sort") !== "ascending";
      table.querySelectorAll("th").forEach((h) => h.removeAttribute("aria-sort"));
      th.setAttribute("aria-sort", ascending ? "ascending" : "descending");
      const body = table.tBodies[0];
      const rows = Array.from(body.rows);
      rows.sort((a, b) => {
        const x = a.sortValues[key], y = b.sortValues[key];
        if (x == null && y == null) return 0;
        if (x == null) return 1;
        if (y == null) return -1;
        const c = typeof x === "string" ? x.localeCompare(y) : x - y;
        return ascending ? c : -c;
      });
      rows.forEach((r) => body.append(r));
    }));
  }

  // ---- one section per scene
  const container = document.getElementById("scenes");
  for (const entry of data.scenes) container.append(section(entry));

  function section(entry) {
    const variants = Object.keys(entry.variants);
    const s = {entry, variant: variants[0], mode: "wipe", split: 50, visible: false, key: ""};
    scenes.push(s);
    const sec = el("section", {class: "scene", id: "scene-" + entry.folder});
    s.el = sec;
    sec.append(el("h2", {text: entry.name},
      entry.failing ? el("span", {class: "badge", text: "above the FLIP limit"}) : null));
    const src = entry.source || {};
    sec.append(el("div", {class: "dim", text: [src.blend_file, src.scene && "scene " + src.scene,
      entry.resolution && entry.resolution.join(" \u00d7 "),
      entry.color_management && entry.color_management.view_transform].filter(Boolean).join(" \u00b7 ")}));
    const modes = el("div", {class: "buttons modes"});
    for (const [m, label] of [["wipe", "A/B wipe"], ["difference", "Difference"],
                              ["flip_ldr", "FLIP LDR"], ["flip_hdr", "FLIP HDR"]]) {
      if (m.startsWith("flip") && !entry.variants[s.variant].pictures[m]) continue;
      modes.append(el("button", {type: "button", "data-mode": m, "aria-pressed": String(m === s.mode), text: label}));
    }
    const row = el("div", {class: "row"}, modes);
    if (variants.length > 1) {
      const vb = el("div", {class: "buttons variants"});
      for (const v of variants) {
        vb.append(el("button", {type: "button", "data-variant": v, "aria-pressed": String(v === s.variant),
          text: v === "bo2" ? "New methods" : "Old methods", title: entry.variants[v].label}));
      }
      row.append(vb);
    }
    const times = el("span", {class: "dim times"});
    row.append(times);
    sec.append(row);
    const base = el("img", {class: "base", alt: "Cycles", loading: "lazy", src: entry.cycles_pictures.cycles});
    const topImg = el("img", {alt: "BO2 Lighting", loading: "lazy"});
    const width = (entry.resolution || [0])[0];
    if (width && width < MIN_WIDTH) {  // small renders enlarged, pixel for pixel
      base.style.width = MIN_WIDTH + "px";
      base.classList.add("enlarged"); topImg.classList.add("enlarged");
    }
    const top = el("div", {class: "top"}, topImg);
    const divider = el("div", {class: "divider"});
    const viewer = el("div", {class: "viewer"}, base, top, divider,
      el("span", {class: "tag", style: "left:6px", text: "BO2 Lighting"}),
      el("span", {class: "tag", style: "right:6px", text: "Cycles"}));
    const wipe = el("input", {class: "wipe", type: "range", min: "0", max: "100", step: "0.1",
                              value: "50", "aria-label": "A/B wipe position"});
    const legend = el("div", {class: "legend"});
    sec.append(el("div", {class: "stage"}, viewer, wipe), legend);
    const table = el("table", {class: "passes"});
    table.innerHTML = "<thead><tr><th class='text' data-key='pass'>Pass</th><th data-key='flip_ldr'>FLIP LDR</th>" +
      "<th data-key='psnr_db'>PSNR dB</th><th data-key='ssim'>SSIM</th><th data-key='rmse'>RMSE</th>" +
      "<th data-key='mean_relative_error'>Rel. error</th></tr></thead><tbody></tbody>";
    sortable(table);
    const links = el("div", {class: "dim links"}, "Full EXRs: ");
    for (const [k, href] of Object.entries(entry.links || {})) {
      links.append(el("a", {href, text: k === "cycles" ? "Cycles" : entry.variants[k] ? entry.variants[k].label : k}), " ");
    }
    sec.append(table, links);
    Object.assign(s, {base, topImg, top, divider, viewer, wipe, legend, table, times, modes});

    modes.addEventListener("click", (ev) => {
      const b = ev.target.closest("button"); if (!b) return;
      s.mode = b.dataset.mode; update(s);
    });
    row.addEventListener("click", (ev) => {
      const b = ev.target.closest("button[data-variant]"); if (!b) return;
      s.variant = b.dataset.variant; s.key = ""; update(s);
    });
    wipe.addEventListener("input", () => { s.split = Number(wipe.value); placeSplit(s); });
    const drag = (ev) => {
      if (s.mode !== "wipe" || !(ev.buttons & 1)) return;
      const r = viewer.getBoundingClientRect();
      s.split = Math.min(100, Math.max(0, (ev.clientX - r.left) / r.width * 100));
      wipe.value = String(s.split); placeSplit(s);
    };
    viewer.addEventListener("pointerdown", (ev) => { viewer.setPointerCapture(ev.pointerId); drag(ev); });
    viewer.addEventListener("pointermove", drag);
    update(s);
    return sec;
  }

  function placeSplit(s) {
    s.top.style.clipPath = `inset(0 ${100 - s.split}% 0 0)`;
    s.divider.style.left = `calc(${s.split}% - 1px)`;
  }

  function update(s) {
    const entry = s.entry, v = entry.variants[s.variant];
    s.modes.querySelectorAll("button").forEach((b) => b.setAttribute("aria-pressed", String(b.dataset.mode === s.mode)));
    s.el.querySelectorAll("button[data-variant]").forEach((b) => b.setAttribute("aria-pressed", String(b.dataset.variant === s.variant)));
    const wipe = s.mode === "wipe";
    s.viewer.classList.toggle("single", !wipe);
    s.wipe.style.display = wipe ? "" : "none";
    if (wipe) {
      setPictures(s);
    } else {
      s.base.src = v.pictures[s.mode === "difference" ? "difference" : s.mode];
      s.key = "";
    }
    placeSplit(s);
    s.legend.replaceChildren();
    if (s.mode === "difference") {
      s.legend.append("0", el("span", {class: "bar", style: "background:" + data.heat_gradient}),
        `${entry.heat_scale_max} \u2003|Y(BO2) \u2212 Y(Cycles)|, scene-linear luminance`);
    } else if (s.mode.startsWith("flip")) {
      s.legend.append("0", el("span", {class: "bar", style: "background:" + MAGMA}),
        `1 \u2003${s.mode === "flip_ldr" ? "LDR" : "HDR"}-FLIP, mean ` +
        fmt(v.metrics.Combined[s.mode], 4));
    }
    const t = v.seconds, c = entry.cycles_seconds;
    s.times.textContent = `BO2 ${fmtSeconds(t)} s` + (v.samples ? ` (${v.samples} spp)` : "") +
      ` \u00b7 Cycles ${fmtSeconds(c)} s` + (entry.samples && entry.samples.cycles ? ` (${entry.samples.cycles} spp)` : "") +
      (t && c ? ` \u00b7 speed-up ${(c / t).toFixed(1)}\u00d7` : "");
    const body = s.table.tBodies[0];
    body.replaceChildren();
    s.table.querySelectorAll("th").forEach((h) => h.removeAttribute("aria-sort"));
    for (const [name, m] of Object.entries(v.metrics)) {
      const r = el("tr", {}, el("td", {class: "text", text: name}), el("td", {text: fmt(m.flip_ldr, 4)}),
        el("td", {text: fmt(m.psnr_db, 2)}), el("td", {text: fmt(m.ssim, 3)}), el("td", {text: fmt(m.rmse, 4)}),
        el("td", {text: fmt(m.mean_relative_error, 3)}));
      r.sortValues = {pass: name, ...m};
      body.append(r);
    }
  }

  // ---- exposure and view transforms on the scene-linear renders
  const srgb = (x) => (x <= 0.0031308 ? 12.92 * x : 1.055 * Math.pow(x, 1 / 2.4) - 0.055);
  function neutral(c) {  // Khronos PBR Neutral, in place on [r, g, b]
    const start = 0.8 - 0.04, desat = 0.15;
    const x = Math.min(c[0], c[1], c[2]);
    const offset = x < 0.08 ? x - 6.25 * x * x : 0.04;
    for (let i = 0; i < 3; i++) c[i] -= offset;
    const peak = Math.max(c[0], c[1], c[2]);
    if (peak < start) return c;
    const d = 1 - start, newPeak = 1 - d * d / (peak + d - start);
    for (let i = 0; i < 3; i++) c[i] *= newPeak / peak;
    const g = 1 - 1 / (desat * (peak - newPeak) + 1);
    for (let i = 0; i < 3; i++) c[i] = c[i] * (1 - g) + newPeak * g;
    return c;
  }
  function setPictures(s) {
    const entry = s.entry, v = entry.variants[s.variant];
    if (view.value === "rendered") {
      s.base.src = entry.cycles_pictures.cycles;
      s.topImg.src = v.pictures.render;
      s.key = "";
      return;
    }
    if (!s.visible) return;  // done when the scene scrolls into view
    const key = `${view.value} ${exposure.value} ${s.variant}`;
    if (s.key === key) return;
    withHdr(entry, (images) => {
      const now = `${view.value} ${exposure.value} ${s.variant}`;
      if (s.mode !== "wipe" || view.value === "rendered" || s.key === now) return;
      s.base.src = tonemap(images.cycles);
      s.topImg.src = tonemap(images[s.variant]);
      s.key = now;
    });
  }
  function tonemap(image) {
    const canvas = document.createElement("canvas");
    canvas.width = image.w; canvas.height = image.h;
    const ctx = canvas.getContext("2d");
    const out = ctx.createImageData(image.w, image.h);
    const scale = Math.pow(2, Number(exposure.value)), f = image.rgb, o = out.data;
    const useNeutral = view.value === "neutral", c = [0, 0, 0];
    for (let i = 0, j = 0; i < f.length; i += 3, j += 4) {
      c[0] = f[i] * scale; c[1] = f[i + 1] * scale; c[2] = f[i + 2] * scale;
      if (useNeutral) neutral(c);
      for (let k = 0; k < 3; k++) o[j + k] = Math.round(255 * srgb(Math.min(1, Math.max(0, c[k]))));
      o[j + 3] = 255;
    }
    ctx.putImageData(out, 0, 0);
    return canvas.toDataURL();
  }
  function withHdr(entry, done) {
    const key = entry.folder;
    if (hdr[key] && hdr[key].ready) { done(hdr[key].images); return; }
    (waiting[key] = waiting[key] || []).push(done);
    if (waiting[key].length > 1) return;
    const script = el("script", {src: entry.cycles_pictures.hdr});
    script.onerror = () => {
      waiting[key] = [];
      script.remove();
      const s = scenes.find((x) => x.entry === entry);
      s.legend.replaceChildren(`${entry.cycles_pictures.hdr} is missing: only "As rendered" can be shown`);
    };
    document.head.append(script);
  }
  function hdrLoaded(folder, urls) {
    const images = {}, names = Object.keys(urls);
    let left = names.length;
    for (const name of names) {
      const img = new Image();
      img.onload = () => {  // mantissas in the top half, the exponents below
        const w = img.width, h = img.height / 2;
        const canvas = document.createElement("canvas");
        canvas.width = w; canvas.height = 2 * h;
        const ctx = canvas.getContext("2d", {willReadFrequently: true});
        ctx.drawImage(img, 0, 0);
        const px = ctx.getImageData(0, 0, w, 2 * h).data;
        const rgb = new Float32Array(w * h * 3), n = w * h * 4;
        for (let i = 0, j = 0; i < n; i += 4, j += 3) {
          const e = px[n + i];
          if (e === 0) continue;
          const f = Math.pow(2, e - 136);
          rgb[j] = (px[i] + 0.5) * f; rgb[j + 1] = (px[i + 1] + 0.5) * f; rgb[j + 2] = (px[i + 2] + 0.5) * f;
        }
        images[name] = {w, h, rgb};
        if (--left === 0) {
          hdr[folder] = {ready: true, images};
          for (const cb of waiting[folder] || []) cb(images);
          waiting[folder] = [];
        }
      };
      img.src = urls[name];
    }
  }
  function refreshAll() {
    const rendered = view.value === "rendered";
    exposure.disabled = rendered;
    exposureValue.textContent = `${Number(exposure.value).toFixed(1)} EV`;
    for (const s of scenes) if (s.mode === "wipe") setPictures(s);
  }
  view.addEventListener("change", () => {
    if (view.value !== "rendered" && exposure.disabled) {
      const cm = (data.scenes[0] || {}).color_management;  // start at the files' exposure
      exposure.value = String(cm && cm.exposure ? cm.exposure : 0);
    }
    refreshAll();
  });
  let frame = 0;  // one refresh per frame however fast the slider moves
  exposure.addEventListener("input", () => {
    exposureValue.textContent = `${Number(exposure.value).toFixed(1)} EV`;
    if (!frame) frame = requestAnimationFrame(() => { frame = 0; refreshAll(); });
  });
  const observer = new IntersectionObserver((items) => {
    for (const it of items) {
      const s = scenes.find((x) => x.el === it.target);
      s.visible = it.isIntersecting;
      if (s.visible && s.mode === "wipe") setPictures(s);
    }
  }, {rootMargin: "200px"});
  scenes.forEach((s) => observer.observe(s.el));
  refreshAll();
  return {hdrLoaded, data};
})();

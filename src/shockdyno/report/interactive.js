/* shockdyno report: the interactive plots, drawn by uPlot (inlined above, MIT).
 *
 * Everything the plots need is on the page: the data in <script id="sd-data">, the
 * library before this script. Nothing is fetched. Without JavaScript (or in print) the
 * PNG beside each plot is shown instead (the page's CSS swaps them).
 *
 * Every plot is uPlot's "mode 2" (each series its own x and y): loops are not functions
 * of x. Hover shows the nearest point of a visible series; drag draws a box to zoom,
 * double-click resets; the legend's buttons hide and show series.
 */
(function () {
  "use strict";
  document.documentElement.classList.add("js");
  var store = JSON.parse(document.getElementById("sd-data").textContent);
  var HINT = "hover for values; drag a box to zoom, double-click to reset";
  var PICK_PX = 30; // farther than this from every point: no readout

  function column(ref) {
    // "loop id.key" names a shared loop column (an F-x and an F-v plot share F).
    if (typeof ref === "string") {
      var dot = ref.lastIndexOf(".");
      return store.loops[ref.slice(0, dot)][ref.slice(dot + 1)];
    }
    return ref;
  }

  function fmt(v) {
    return String(+v.toPrecision(4));
  }

  function readout(u, el, spec) {
    var out = el.querySelector(".sd-readout");
    var left = u.cursor.left, top = u.cursor.top;
    var best = null, bestD = PICK_PX * PICK_PX;
    if (left != null && left >= 0) {
      for (var i = 1; i < u.series.length; i++) {
        if (!u.series[i].show) continue;
        var xs = u.data[i][0], ys = u.data[i][1];
        for (var j = 0; j < xs.length; j++) {
          var dx = u.valToPos(xs[j], "x") - left, dy = u.valToPos(ys[j], "y") - top;
          var d = dx * dx + dy * dy;
          if (d < bestD) { bestD = d; best = [i, j]; }
        }
      }
    }
    var mark = el._mark;
    if (!best) {
      out.textContent = HINT;
      mark.style.display = "none";
      return;
    }
    var s = spec.series[best[0] - 1], k = best[1];
    var x = u.data[best[0]][0][k], y = u.data[best[0]][1][k];
    var unit = function (u) { return u ? " " + u : ""; };
    out.textContent = s.label + ": " + spec.x_name + " " + fmt(x) + unit(spec.x_unit) + ", " +
      spec.y_name + " " + fmt(y) + unit(spec.y_unit) + (s.notes ? s.notes[k] : "");
    mark.style.display = "block";
    mark.style.left = u.valToPos(x, "x") - 4 + "px";
    mark.style.top = u.valToPos(y, "y") - 4 + "px";
    mark.style.borderColor = s.colour;
  }

  function padded(u, lo, hi) {
    // mode 2 fits the data exactly: markers at the ends would be cut in half.
    var pad = (hi - lo) * 0.04 || Math.abs(hi) * 0.1 || 1;
    return [lo - pad, hi + pad];
  }

  function drawMarkers(u, spec) {
    var ctx = u.ctx, r = 3.5 * devicePixelRatio;
    ctx.save();
    ctx.beginPath();
    ctx.rect(u.bbox.left, u.bbox.top, u.bbox.width, u.bbox.height);
    ctx.clip();
    spec.series.forEach(function (s, k) {
      if (!s.points || !u.series[k + 1].show) return;
      var xs = u.data[k + 1][0], ys = u.data[k + 1][1];
      ctx.fillStyle = s.hollow ? "#fff" : s.colour;
      ctx.strokeStyle = s.colour;
      ctx.lineWidth = 1.5 * devicePixelRatio;
      for (var j = 0; j < xs.length; j++) {
        if (xs[j] == null || ys[j] == null) continue;
        ctx.beginPath();
        ctx.arc(u.valToPos(xs[j], "x", true), u.valToPos(ys[j], "y", true), r, 0, 2 * Math.PI);
        ctx.fill();
        ctx.stroke();
      }
    });
    ctx.restore();
  }

  function build(el) {
    var host = el.querySelector(".sd-plot");
    if (el._uplot || !host.clientWidth) return; // in a closed block: built when opened
    var spec = store.charts[el.getAttribute("data-chart")];
    var data = [null], series = [{}];
    spec.series.forEach(function (s) {
      data.push([column(s.x), column(s.y)]);
      series.push({
        label: s.label,
        stroke: s.colour,
        width: s.width,
        dash: s.dash ? [6, 4] : (s.dotted ? [2, 3] : undefined),
        paths: s.line ? undefined : function () { return null; },
        points: {show: false}, // markers: drawMarkers (uPlot's skip mode 2 here)
        facets: [{scale: "x", auto: true}, {scale: "y", auto: true}],
      });
    });
    var axisX = {stroke: "#333", grid: {stroke: "#eee"}};
    if (spec.x_integer) axisX.incrs = [1, 2, 5, 10, 20, 50];
    var u = new uPlot({
      mode: 2,
      width: host.clientWidth,
      height: 300,
      legend: {show: false},
      cursor: {drag: {x: true, y: true, uni: 20}, points: {show: false}},
      scales: {x: {time: false, range: padded}, y: {range: padded}},
      axes: [axisX, {stroke: "#333", grid: {stroke: "#eee"}, size: 56}],
      series: series,
      hooks: {
        setCursor: [function (u) { readout(u, el, spec); }],
        draw: [function (u) { drawMarkers(u, spec); }],
      },
    }, data, host);
    var mark = document.createElement("div");
    mark.className = "sd-mark";
    u.over.appendChild(mark);
    el._mark = mark;
    u.over.addEventListener("dblclick", function () { u.setData(u.data, true); });
    el.querySelectorAll(".sd-legend button").forEach(function (b) {
      b.addEventListener("click", function () {
        var on = b.classList.toggle("off");
        b.getAttribute("data-series").split(",").forEach(function (i) {
          u.setSeries(+i, {show: !on});
        });
      });
    });
    el._uplot = u;
  }

  function buildIn(root) {
    root.querySelectorAll(".sd-chart").forEach(build);
  }

  buildIn(document);
  document.querySelectorAll("details").forEach(function (d) {
    d.addEventListener("toggle", function () { if (d.open) buildIn(d); });
  });
  var pending = 0;
  window.addEventListener("resize", function () {
    clearTimeout(pending);
    pending = setTimeout(function () {
      document.querySelectorAll(".sd-chart").forEach(function (el) {
        var host = el.querySelector(".sd-plot");
        if (el._uplot && host.clientWidth) el._uplot.setSize({width: host.clientWidth, height: 300});
        else build(el);
      });
    }, 100);
  });
})();

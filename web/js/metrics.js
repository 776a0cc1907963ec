// Prometheus' text format as the status page reads it: a /metrics body parsed into samples, and the figures made of
// two scrapes (rates per second, quantiles of a histogram's new observations).

/// Parses a /metrics body: {types: {family: type}, samples: [{name, labels: {name: value}, value}]}. Throws an Error
/// naming the line that is not of the format.
export function parseMetrics(text) {
  const types = {};
  const samples = [];
  const line = /^([a-zA-Z_:][a-zA-Z0-9_:]*)(?:\{(.*)\})? (\S+)$/;
  const label = /([a-zA-Z_][a-zA-Z0-9_]*)="((?:[^"\\]|\\.)*)",?/gy;
  for (const l of text.split("\n")) {
    if (!l) continue;
    if (l.startsWith("#")) {
      const m = /^# TYPE (\S+) (\S+)$/.exec(l);
      if (m) types[m[1]] = m[2];
      continue;
    }
    const m = line.exec(l);
    if (!m) throw new Error(`not a line of the metrics format: ${l.slice(0, 120)}`);
    const labels = {};
    if (m[2]) {
      label.lastIndex = 0;
      let lm;
      while (label.lastIndex < m[2].length && (lm = label.exec(m[2])))
        labels[lm[1]] = lm[2].replace(/\\(.)/g, (_, c) => (c === "n" ? "\n" : c));
      if (label.lastIndex !== m[2].length) throw new Error(`bad labels: ${l.slice(0, 120)}`);
    }
    samples.push({ name: m[1], labels, value: m[3] === "+Inf" ? Infinity : Number(m[3]) });
  }
  return { types, samples };
}

/// The samples of `name` whose labels include `match` ({label: value}).
export function select(parsed, name, match = {}) {
  return parsed.samples.filter(
    (s) => s.name === name && Object.entries(match).every(([k, v]) => s.labels[k] === v),
  );
}

/// The sum of the samples of `name` matching `match` (0 if none).
export function total(parsed, name, match = {}) {
  return select(parsed, name, match).reduce((sum, s) => sum + s.value, 0);
}

/// The values of the label `by` among the samples of `name`, in the order written.
export function labelValues(parsed, name, by) {
  return [...new Set(select(parsed, name).map((s) => s.labels[by]))].filter((v) => v !== undefined);
}

/// How fast the counter `name` (matching `match`) grew from scrape `a` to scrape `b`, `seconds` apart, per second; a
/// counter that went down (the server restarted) counts from 0.
export function rate(a, b, seconds, name, match = {}) {
  if (!a || !(seconds > 0)) return 0;
  const now = total(b, name, match);
  const before = total(a, name, match);
  return (now >= before ? now - before : now) / seconds;
}

/// The cumulative buckets of histogram `name` (matching `match`) in one scrape: [{le, count}], ascending.
export function buckets(parsed, name, match = {}) {
  const byLe = new Map();
  for (const s of select(parsed, `${name}_bucket`, match)) {
    const le = s.labels.le === "+Inf" ? Infinity : Number(s.labels.le);
    byLe.set(le, (byLe.get(le) || 0) + s.value);
  }
  return [...byLe.entries()].sort((x, y) => x[0] - y[0]).map(([le, count]) => ({ le, count }));
}

/// The `q` quantile (0..1) of the observations of histogram `name` made between scrapes `a` and `b` (all of `b`'s
/// when `a` is null), interpolated linearly within a bucket as Prometheus' histogram_quantile does; null when none
/// were made. Past the last finite bound it is that bound.
export function quantile(a, b, name, q, match = {}) {
  const now = buckets(b, name, match);
  const before = a ? new Map(buckets(a, name, match).map((x) => [x.le, x.count])) : new Map();
  const counts = now.map((x) => ({ le: x.le, count: Math.max(0, x.count - (before.get(x.le) || 0)) }));
  const n = counts.length ? counts[counts.length - 1].count : 0;
  if (!n) return null;
  const rank = q * n;
  let lower = 0;
  let below = 0;
  for (const { le, count } of counts) {
    if (count >= rank) {
      if (le === Infinity) return lower;
      return lower + ((le - lower) * (rank - below)) / Math.max(1, count - below);
    }
    lower = le;
    below = count;
  }
  return lower;
}

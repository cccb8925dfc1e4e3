// Numbers and planner values as short text.

export function seconds(s) {
  if (s === null || s === undefined || Number.isNaN(s)) return "–";
  if (s === 0) return "0 s";
  if (s < 0.001) return `${(s * 1e6).toFixed(0)} µs`;
  if (s < 1) return `${(s * 1000).toFixed(s < 0.01 ? 2 : 1)} ms`;
  if (s < 100) return `${s.toFixed(2)} s`;
  return `${s.toFixed(0)} s`;
}

export function num(x, digits = 3) {
  if (x === null || x === undefined) return "–";
  if (typeof x !== "number") return String(x);
  if (Number.isInteger(x)) return String(x);
  const a = Math.abs(x);
  if (a !== 0 && (a < 1e-3 || a >= 1e5)) return x.toExponential(2);
  return String(Number(x.toFixed(digits)));
}

/**
 * A planner value (JSON from the domain's codec) as compact text: numbers rounded, long lists
 * cut, typed values by their type and first fields ("pose x=1.2 y=0.3 …"). The inspector shows
 * the domain's own label instead when the events carry one.
 */
export function value(v, depth = 0) {
  if (v === null || v === undefined) return "null";
  if (typeof v === "number") return num(v);
  if (typeof v === "string") return v;
  if (typeof v === "boolean") return String(v);
  if (Array.isArray(v)) {
    if (depth > 2) return `[${v.length} items]`;
    const head = v.slice(0, 7).map((x) => value(x, depth + 1));
    return `[${head.join(", ")}${v.length > 7 ? `, … ${v.length} items` : ""}]`;
  }
  if (typeof v === "object") {
    if (depth > 2) return "{…}";
    const keys = Object.keys(v).filter((k) => k !== "type");
    const parts = keys.slice(0, 8).map((k) => `${k}=${value(v[k], depth + 1)}`);
    if (keys.length > 8) parts.push("…");
    return (typeof v.type === "string" ? `${v.type} ` : "") + parts.join(" ");
  }
  return String(v);
}

export function when(iso) {
  if (!iso) return "";
  const d = new Date(iso);
  if (Number.isNaN(d.getTime())) return iso;
  const sameDay = d.toDateString() === new Date().toDateString();
  return sameDay
    ? d.toLocaleTimeString([], { hour: "2-digit", minute: "2-digit", second: "2-digit" })
    : d.toLocaleString([], { month: "short", day: "numeric", hour: "2-digit", minute: "2-digit" });
}

export function escapeHtml(s) {
  return String(s).replace(
    /[&<>"']/g,
    (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" })[c],
  );
}

const NUMBER = new Intl.NumberFormat("en-US");

/** A count with thousands separators ("12,345"); one formatter for all (toLocaleString made a
 * new one on every call, on every step of the replay). */
export function count(n) {
  return NUMBER.format(n);
}

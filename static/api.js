// The REST API of docs/dashboard.md, and the text of its errors.

export class ApiError extends Error {
  constructor(status, message) {
    super(message);
    this.status = status;
  }
}

/** Fetch JSON; a non-2xx answer throws an ApiError whose message is the server's detail. */
export async function api(path, { method = "GET", body } = {}) {
  const init = { method, headers: { Accept: "application/json" } };
  if (body !== undefined) {
    init.headers["Content-Type"] = "application/json";
    init.body = JSON.stringify(body);
  }
  let response;
  try {
    response = await fetch(path, init);
  } catch (err) {
    throw new ApiError(0, `cannot reach the server (${err.message})`);
  }
  const text = await response.text();
  let data = null;
  try {
    data = text ? JSON.parse(text) : null;
  } catch {
    data = text;
  }
  if (!response.ok) {
    throw new ApiError(response.status, `${response.status}: ${errorText(data, response)}`);
  }
  return data;
}

/** FastAPI error bodies as one readable line per problem. */
export function errorText(data, response) {
  const detail = data && typeof data === "object" && "detail" in data ? data.detail : data;
  if (Array.isArray(detail)) {
    return detail
      .map((d) => {
        if (d === null || typeof d !== "object") return String(d);
        const loc = (d.loc ?? []).filter((p) => p !== "body" && p !== "query");
        return loc.length ? `${loc.join(".")}: ${d.msg}` : String(d.msg ?? JSON.stringify(d));
      })
      .join("\n");
  }
  if (typeof detail === "string" && detail) return detail;
  if (detail && typeof detail === "object") return JSON.stringify(detail);
  return response.statusText || "request failed";
}

export function streamUrl(runId, after) {
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  return `${scheme}://${location.host}/api/runs/${encodeURIComponent(runId)}/stream?after=${after}`;
}

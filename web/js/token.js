// The access token a page was opened with (?token=TOKEN): taken out of the address as soon as the page loads, so that
// it is not left in the history, in bookmarks, in a shared link or on a screen showing the address bar, and kept in
// memory for /ws, /presets.json, /metrics and the link to the other page.

/// Removes `token` from `params` (the page's URLSearchParams) and from the address (history.replaceState, the rest of
/// the address kept); returns it, or null when the address had none.
export function takeToken(params) {
  const token = params.get("token");
  if (token === null) return null;
  params.delete("token");
  const query = params.toString();
  history.replaceState(history.state, "", `${location.pathname}${query ? `?${query}` : ""}${location.hash}`);
  return token;
}

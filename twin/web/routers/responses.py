"""Refusals the routes document (OpenAPI `responses`), shared by the routers."""

from __future__ import annotations

from typing import Any

from twin.web.limits import MAX_BODY

#: what any mutating route may answer before its handler runs
REFUSED: dict[int | str, dict[str, Any]] = {
    400: {"description": "a Host this server does not answer to, a body that is not UTF-8 "
          "JSON text, or a bad Content-Length"},
    401: {"description": "missing or wrong token (the server has one)"},
    403: {"description": "a browser request from an origin other than the server's own"},
    413: {"description": f"body over {MAX_BODY} bytes (the default cap)"},
    429: {"description": "too many wrong tokens from this client: retry after the Retry-After "
          "header's seconds"},
}  # fmt: skip
#: the run store's file was deleted or replaced while the server runs
STORE: dict[int | str, dict[str, Any]] = {
    503: {"description": "the run store's file is gone or replaced (nothing was stored)"},
}
BAD_INPUT = {
    **REFUSED,
    422: {"description": "bad input: each field, its problem and allowed range"},
}
LIMITED = {
    **BAD_INPUT,
    **STORE,
    507: {"description": "the run store is full (--max-store, --max-runs): delete runs or "
          "sweeps, or start the server with a larger quota or --retain"},
    429: {"description": "too many submissions (or wrong tokens) from this client, or the "
          "queue is full: retry after the Retry-After header's seconds"},
}  # fmt: skip

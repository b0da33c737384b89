"""Consistent error bodies for every failure.

Every error answer has the same shape::

    {"error": {"status": 404, "code": "not_found", "message": "resident 7 not found",
               "details": []}}

``details`` lists the offending fields for 422 answers (``loc`` and ``msg``; the rejected value
is never echoed back).
"""

from __future__ import annotations

import logging
from typing import Any

from fastapi import FastAPI, HTTPException, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import BaseModel, Field
from starlette.exceptions import HTTPException as StarletteHTTPException

from gaitwatch.errors import InputError

log = logging.getLogger(__name__)

CODES = {
    400: "bad_request",
    401: "unauthorized",
    403: "forbidden",
    404: "not_found",
    405: "method_not_allowed",
    409: "conflict",
    413: "payload_too_large",
    422: "validation_error",
    500: "internal_error",
    503: "unavailable",
}


class ErrorDetail(BaseModel):
    """One offending field."""

    loc: list[str | int] = Field(..., examples=[["query", "limit"]])
    msg: str = Field(..., examples=["Input should be less than or equal to 500"])


class ErrorInfo(BaseModel):
    status: int = Field(..., examples=[404])
    code: str = Field(..., examples=["not_found"])
    message: str = Field(..., examples=["resident 7 not found"])
    details: list[ErrorDetail] = Field(default_factory=list)


class ErrorBody(BaseModel):
    """The body of every error answer."""

    error: ErrorInfo


def error_response(
    status: int,
    message: str,
    details: list[dict[str, Any]] | None = None,
    headers: dict[str, str] | None = None,
    code: str | None = None,
) -> JSONResponse:
    body = {
        "error": {
            "status": status,
            "code": code or CODES.get(status, "error"),
            "message": message,
            "details": details or [],
        }
    }
    return JSONResponse(body, status_code=status, headers=headers)


class ApiError(HTTPException):
    """An HTTP error with a machine-readable ``code``."""

    def __init__(
        self,
        status: int,
        message: str,
        code: str | None = None,
        headers: dict[str, str] | None = None,
    ) -> None:
        super().__init__(status_code=status, detail=message, headers=headers)
        self.code = code


def not_found(what: str) -> ApiError:
    return ApiError(404, f"{what} not found")


def forbidden(message: str = "this API key's role may not do that") -> ApiError:
    return ApiError(403, message)


# Responses to document on routes (OpenAPI).
def responses(*codes: int) -> dict[int | str, dict[str, Any]]:
    text = {
        401: "No API key, or an unknown or revoked one.",
        403: "The key's role may not do this.",
        404: "Unknown, or not assigned to this caregiver key.",
        409: "The request conflicts with the current state.",
        422: "Invalid parameters or body.",
    }
    return {c: {"model": ErrorBody, "description": text.get(c, "Error")} for c in codes}


def install(app: FastAPI) -> None:
    """Register the handlers that produce the error body above."""

    @app.exception_handler(StarletteHTTPException)
    async def _http(_req: Request, exc: StarletteHTTPException) -> JSONResponse:
        msg = exc.detail if isinstance(exc.detail, str) else CODES.get(exc.status_code, "error")
        if exc.status_code == 404 and msg == "Not Found":
            msg = "no such endpoint"
        return error_response(
            exc.status_code,
            msg,
            headers=getattr(exc, "headers", None),
            code=getattr(exc, "code", None),
        )

    @app.exception_handler(RequestValidationError)
    async def _validation(_req: Request, exc: RequestValidationError) -> JSONResponse:
        details = [
            {
                "loc": [str(p) if not isinstance(p, int) else p for p in e.get("loc", ())],
                "msg": str(e.get("msg", ""))[:300],
            }
            for e in exc.errors()[:20]
        ]
        first = details[0] if details else {"loc": [], "msg": "invalid request"}
        where = ".".join(str(p) for p in first["loc"])
        return error_response(422, f"{where}: {first['msg']}" if where else first["msg"], details)

    @app.exception_handler(InputError)
    async def _input(_req: Request, exc: InputError) -> JSONResponse:
        return error_response(422, str(exc).replace("\n", " ")[:500])

    @app.exception_handler(Exception)
    async def _internal(_req: Request, exc: Exception) -> JSONResponse:
        log.exception("unhandled error: %s", exc)
        return error_response(500, "internal error (logged on the server)")

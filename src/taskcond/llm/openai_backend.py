"""Any OpenAI-compatible chat endpoint (OpenAI, vLLM, Ollama, a llama.cpp server) through the official
``openai`` SDK (the ``[openai]`` extra).

Transport errors (unreachable endpoint, rejected key, time-out, HTTP errors) become one-line
:class:`LLMError` messages naming the endpoint; the API key never appears in them.
"""

from __future__ import annotations

import time
from typing import Any

from taskcond.llm.base import ChatRequest, ChatResponse, LLMError


class OpenAIBackend:
    """Chat completions against ``base_url`` (``None``: the SDK's default, api.openai.com).

    Args:
        model: model name on the endpoint.
        base_url: endpoint URL ending in ``/v1``.
        api_key: the key; never logged or printed.
        timeout: seconds per request.
        max_retries: SDK-level retries of connection errors, 429 and 5xx answers.
        grammar_field: request field that carries a GBNF grammar for endpoints that support constrained
            decoding (``"grammar"`` for llama.cpp servers); ``None`` sends no grammar and relies on the
            generator's validator.
    """

    name = "openai"

    def __init__(
        self,
        model: str,
        base_url: str | None,
        api_key: str,
        timeout: float = 60.0,
        max_retries: int = 2,
        grammar_field: str | None = None,
    ) -> None:
        try:
            import openai
        except ImportError:
            raise LLMError(
                "the openai package is not installed; install it with pip install 'taskcond[openai]'",
                backend=self.name,
            ) from None
        self.model = model
        self.base_url = base_url
        self.grammar_field = grammar_field
        self._secret = api_key
        self._openai = openai
        self._client = openai.OpenAI(
            api_key=api_key, base_url=base_url, timeout=timeout, max_retries=max_retries
        )

    @property
    def endpoint(self) -> str:
        return self.base_url or "https://api.openai.com/v1"

    def _clean(self, text: str) -> str:
        text = " ".join(str(text).split())
        if self._secret:
            text = text.replace(self._secret, "***")
        return text[:300]

    def chat(self, request: ChatRequest) -> ChatResponse:
        o = self._openai
        s = request.sampling
        extra: dict[str, Any] = {}
        if self.grammar_field and request.grammar:
            extra[self.grammar_field] = request.grammar
        start = time.perf_counter()
        where = f"endpoint {self.endpoint}, model {self.model}"
        try:
            out = self._client.chat.completions.create(
                model=self.model,
                messages=[{"role": m.role, "content": m.content} for m in request.messages],  # type: ignore[misc]
                temperature=s.temperature,
                top_p=s.top_p,
                max_tokens=s.max_tokens,
                seed=s.seed,
                stop=list(request.stop) or None,
                extra_body=extra or None,
            )
        except o.AuthenticationError:
            raise LLMError(f"{where} rejected the API key (401); check OPENAI_API_KEY", self.name) from None
        except o.PermissionDeniedError:
            raise LLMError(f"{where} denied access (403)", self.name) from None
        except o.NotFoundError as exc:
            raise LLMError(f"{where}: not found (404): {self._clean(exc.message)}", self.name) from None
        except o.APITimeoutError:
            raise LLMError(f"{where} timed out", self.name) from None
        except o.APIConnectionError:
            raise LLMError(f"cannot reach {where}; is the server running?", self.name) from None
        except o.APIStatusError as exc:
            raise LLMError(
                f"{where} answered HTTP {exc.status_code}: {self._clean(exc.message)}", self.name
            ) from None
        if not out.choices:
            raise LLMError(f"{where} returned no choices", self.name)
        message = out.choices[0].message
        # An empty answer or a refusal is returned as text: the validator rejects it and asks again.
        text = message.content or getattr(message, "refusal", None) or ""
        usage = out.usage
        return ChatResponse(
            text=text,
            prompt_tokens=usage.prompt_tokens if usage else 0,
            completion_tokens=usage.completion_tokens if usage else 0,
            seconds=time.perf_counter() - start,
        )

"""The class inside a school's LMS: an LTI 1.3 tool's sign-in (OIDC login, launch, JWKS).

An LMS (Moodle, Canvas, Brightspace, Schoology) signs a person in to the class by LTI 1.3: the
LMS sends the browser to the tool's *login* address; the tool sends it back to the LMS's
authorisation address with a ``state`` (kept by the tool, and in a cookie of the browser's) and a
``nonce``; the LMS posts the browser to the tool's *launch* address with an ``id_token``, a JSON
Web Token signed with the LMS's key (RS256). The tool checks it whole before it trusts a word of
it: the signature against the LMS's published keys, the issuer, the audience (the client id the
LMS gave the tool), the deployment, the times, the nonce (used once), the state (the one this
browser was given), the message's type and LTI's version. A learner is then signed in to the
student's page, an instructor to the teacher's desk; a launch whose token fails any check is
refused (401) with one line saying which.

What the tool is told of its LMS (:class:`Platform`) is kept in the class's folder as
``lti/platform.json``, written by ``autonomy class lti-config``; its own key pair is
``lti/tool-key.pem``, readable by the teacher alone, and its public half is served as the JWKS.

PyJWT checks the signature and the claims; the times are checked here against this machine's wall
clock (the clock module's), with :data:`LEEWAY_S` for an LMS whose clock is a little off.
"""

from __future__ import annotations

import base64
import collections
import dataclasses
import hashlib
import json
import os
import secrets
import urllib.parse
import urllib.request
from collections.abc import Callable
from pathlib import Path
from typing import Any

from autonomy.clock import wall_time_s
from autonomy.errors import AutonomyError
from autonomy.views.lines import printable

#: The folder of a class's folder that holds its LTI settings and its key.
LTI_FOLDER = "lti"
PLATFORM_FILE = "platform.json"
KEY_FILE = "tool-key.pem"
#: How far an LMS's clock may be off this machine's, seconds (an id_token's exp, iat, nbf).
LEEWAY_S = 60.0
#: How long a login's state waits for its launch, seconds; and how many states wait at once (the oldest let go).
STATE_S = 600.0
STATES_KEPT = 4096
#: How long a nonce is remembered as used, seconds (longer than any id_token a launch takes lives).
NONCE_S = 3600.0
#: How long the LMS's published keys are kept before they are asked for again, seconds.
JWKS_KEPT_S = 600.0
#: Longest an LMS's keys take to be fetched, seconds; most bytes they may be.
JWKS_TIMEOUT_S = 5.0
JWKS_MOST_BYTES = 256 * 1024
#: The name of the cookie that ties a login's state to the browser it was given to.
STATE_COOKIE = "autonomy-lti-state"

_LTI = "https://purl.imsglobal.org/spec/lti/claim/"
INSTRUCTOR_ROLES = (
    "http://purl.imsglobal.org/vocab/lis/v2/membership#Instructor",
    "http://purl.imsglobal.org/vocab/lis/v2/membership#ContentDeveloper",
    "http://purl.imsglobal.org/vocab/lis/v2/institution/person#Administrator",
    "http://purl.imsglobal.org/vocab/lis/v2/system/person#Administrator",
)


class LtiError(AutonomyError):
    """LTI settings that cannot be used (a platform file with problems, a key that cannot be made)."""


class LaunchRefused(Exception):
    """A login or launch the tool does not take; its message is one line saying why."""


@dataclasses.dataclass(frozen=True)
class Platform:
    """What the tool knows of the LMS that launches it.

    Attributes:
        issuer: The LMS's ``iss``, e.g. ``https://moodle.school.example``.
        client_id: The client id the LMS gave this tool (each id_token's audience).
        auth_url: Where the LMS takes the login's answer (its OIDC authorisation address).
        token_url: Where the LMS gives access tokens (for its roster and gradebook).
        jwks_url: Where the LMS publishes its public keys.
        deployment_ids: The deployments of this tool that may launch it.
        jwks: The LMS's keys, given here rather than fetched (a JWKS document), or None.
    """

    issuer: str
    client_id: str
    auth_url: str
    token_url: str
    jwks_url: str
    deployment_ids: tuple[str, ...]
    jwks: dict[str, Any] | None = None


@dataclasses.dataclass(frozen=True)
class Launch:
    """Who a checked launch signs in.

    Attributes:
        subject: The LMS's id of the person (``sub``).
        name: Their name as the LMS gives it (empty if it gives none).
        roster_id: Their institution's id (``lis.person_sourcedid``), empty if none.
        instructor: Whether they teach the course (an instructor's role), else a learner.
        resource_link: The LMS's id of the link that was followed.
    """

    subject: str
    name: str
    roster_id: str
    instructor: bool
    resource_link: str


def lti_folder(class_folder: Path) -> Path:
    return Path(class_folder) / LTI_FOLDER


def read_platform(class_folder: Path) -> Platform | None:
    """The class's LMS, as ``class lti-config`` wrote it; None when it has none.

    Raises:
        LtiError: the file is there but cannot be read, or lacks what a launch needs.
    """
    path = lti_folder(class_folder) / PLATFORM_FILE
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as err:
        raise LtiError(f"{path}: cannot read the LMS's settings: {err}") from err
    if not isinstance(data, dict):
        raise LtiError(f"{path}: the LMS's settings are a JSON object; make them anew with autonomy class lti-config")
    missing = [key for key in ("issuer", "client_id", "auth_url", "deployment_ids") if not data.get(key)]
    if not data.get("jwks_url") and not data.get("jwks"):
        missing.append("jwks_url")
    if missing:
        raise LtiError(f"{path}: the LMS's {', '.join(missing)} missing: give them to autonomy class lti-config")
    ids = data["deployment_ids"]
    if not isinstance(ids, list) or not all(isinstance(i, str) and i for i in ids):
        raise LtiError(f"{path}: deployment_ids is a list of the LMS's deployment ids")
    return Platform(
        str(data["issuer"]),
        str(data["client_id"]),
        str(data["auth_url"]),
        str(data.get("token_url", "")),
        str(data.get("jwks_url", "")),
        tuple(ids),
        data.get("jwks") if isinstance(data.get("jwks"), dict) else None,
    )


def write_platform(class_folder: Path, platform: Platform) -> Path:
    """Keeps the class's LMS settings (the teacher's alone); the file's path."""
    folder = lti_folder(class_folder)
    folder.mkdir(mode=0o700, parents=True, exist_ok=True)
    path = folder / PLATFORM_FILE
    data = dataclasses.asdict(platform)
    data["deployment_ids"] = list(platform.deployment_ids)
    if data["jwks"] is None:
        del data["jwks"]
    path.write_text(json.dumps(data, indent=2) + "\n", encoding="utf-8")
    path.chmod(0o600)
    return path


def _b64(number: int) -> str:
    raw = number.to_bytes((number.bit_length() + 7) // 8, "big")
    return base64.urlsafe_b64encode(raw).rstrip(b"=").decode("ascii")


class ToolKey:
    """The tool's own RSA key pair, kept in the class's folder (made at first use, readable by its owner alone).

    Raises:
        LtiError: the key cannot be read or made.
    """

    def __init__(self, class_folder: Path) -> None:
        from cryptography.hazmat.primitives import serialization
        from cryptography.hazmat.primitives.asymmetric import rsa

        folder = lti_folder(class_folder)
        path = folder / KEY_FILE
        try:
            folder.mkdir(mode=0o700, parents=True, exist_ok=True)
            if path.is_file():
                key = serialization.load_pem_private_key(path.read_bytes(), password=None)
            else:
                key = rsa.generate_private_key(public_exponent=65537, key_size=2048)
                pem = key.private_bytes(
                    serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption()
                )
                descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
                with os.fdopen(descriptor, "wb") as out:
                    out.write(pem)
        except (OSError, ValueError) as err:
            raise LtiError(f"{path}: cannot keep the tool's key there: {err}") from err
        if not isinstance(key, rsa.RSAPrivateKey):
            raise LtiError(f"{path}: the tool's key is not an RSA key; remove it and a new one is made")
        self.path = path
        self.private = key
        numbers = key.public_key().public_numbers()
        self.kid = hashlib.sha256(f"{numbers.n}:{numbers.e}".encode()).hexdigest()[:16]
        self._public = {"kty": "RSA", "alg": "RS256", "use": "sig", "kid": self.kid, "n": _b64(numbers.n),
                        "e": _b64(numbers.e)}  # fmt: skip

    def jwks(self) -> dict[str, Any]:
        """The tool's public key as a JWKS document (what the LMS checks the tool's signatures with)."""
        return {"keys": [dict(self._public)]}


def tool_urls(base_url: str) -> dict[str, str]:
    """The tool's addresses an LMS's admin pastes in, under ``base_url`` (``https://class.school.example``)."""
    base = base_url.rstrip("/")
    return {
        "tool_url": f"{base}/lti/launch",
        "login_url": f"{base}/lti/login",
        "redirect_uri": f"{base}/lti/launch",
        "jwks_url": f"{base}/lti/jwks",
    }


def canvas_config(base_url: str, title: str) -> dict[str, Any]:
    """Canvas's "paste JSON" developer key configuration of the tool."""
    urls = tool_urls(base_url)
    host = urllib.parse.urlsplit(base_url).hostname or ""
    return {
        "title": title,
        "description": "Behaviour-tree missions for the class's robot: write, run, hand in.",
        "oidc_initiation_url": urls["login_url"],
        "target_link_uri": urls["tool_url"],
        "public_jwk_url": urls["jwks_url"],
        "scopes": [
            "https://purl.imsglobal.org/spec/lti-ags/scope/lineitem",
            "https://purl.imsglobal.org/spec/lti-ags/scope/score",
            "https://purl.imsglobal.org/spec/lti-nrps/scope/contextmembership.readonly",
        ],
        "extensions": [
            {
                "domain": host,
                "platform": "canvas.instructure.com",
                "privacy_level": "public",
                "settings": {
                    "placements": [
                        {
                            "placement": "link_selection",
                            "message_type": "LtiResourceLinkRequest",
                            "target_link_uri": urls["tool_url"],
                        }
                    ]
                },  # fmt: skip
            }
        ],
        "custom_fields": {},
    }


def _fetch_jwks(url: str) -> dict[str, Any]:
    """The LMS's published keys (blocking: called off the server's loop)."""
    request = urllib.request.Request(url, headers={"Accept": "application/json"})
    with urllib.request.urlopen(request, timeout=JWKS_TIMEOUT_S) as answer:  # noqa: S310 - the LMS's, as configured
        body = answer.read(JWKS_MOST_BYTES + 1)
    if len(body) > JWKS_MOST_BYTES:
        raise ValueError(f"more than {JWKS_MOST_BYTES:,} bytes")
    data = json.loads(body)
    if not isinstance(data, dict) or not isinstance(data.get("keys"), list):
        raise ValueError("not a JWKS document (an object with its keys)")
    return data


class LtiTool:
    """The tool's side of LTI 1.3's sign-in: logins answered, launches checked; thread-safe enough for one loop.

    Args:
        platform: The LMS that launches it.
        key: The tool's own key pair.
        fetch_jwks: Fetches the LMS's keys from an address (blocking; the caller runs it off its loop).
    """

    def __init__(
        self, platform: Platform, key: ToolKey, fetch_jwks: Callable[[str], dict[str, Any]] = _fetch_jwks
    ) -> None:
        self.platform = platform
        self.key = key
        self._fetch = fetch_jwks
        #: Each login's state: its nonce and when it lapses, oldest first.
        self._states: collections.OrderedDict[str, tuple[str, float]] = collections.OrderedDict()
        #: Each nonce a launch used, and when it may be forgotten.
        self._used: collections.OrderedDict[str, float] = collections.OrderedDict()
        self._jwks: tuple[dict[str, Any], float] | None = None

    def login(self, given: dict[str, str], redirect_uri: str) -> tuple[str, str]:
        """The answer to an LMS's login initiation: where to send the browser back to, and the state to keep.

        Raises:
            LaunchRefused: the login is not from this class's LMS, or lacks what LTI says it must hold.
        """
        if given.get("iss") != self.platform.issuer:
            raise LaunchRefused(f"a login from {_said(given.get('iss'))}, not from this class's LMS")
        if given.get("client_id") not in (None, "", self.platform.client_id):
            raise LaunchRefused("a login for another tool's client id")
        if not given.get("login_hint"):
            raise LaunchRefused("a login without its login_hint: it did not come from an LMS's launch")
        now_s = wall_time_s()
        self._forget(now_s)
        state, nonce = secrets.token_urlsafe(24), secrets.token_urlsafe(24)
        self._states[state] = (nonce, now_s + STATE_S)
        while len(self._states) > STATES_KEPT:
            self._states.popitem(last=False)
        query = {
            "scope": "openid",
            "response_type": "id_token",
            "response_mode": "form_post",
            "prompt": "none",
            "client_id": self.platform.client_id,
            "redirect_uri": redirect_uri,
            "login_hint": given["login_hint"],
            "state": state,
            "nonce": nonce,
        }
        if given.get("lti_message_hint"):
            query["lti_message_hint"] = given["lti_message_hint"]
        return f"{self.platform.auth_url}?{urllib.parse.urlencode(query)}", state

    def keys(self) -> dict[str, Any]:
        """The LMS's keys: given, kept from a fetch less than :data:`JWKS_KEPT_S` old, or fetched now (blocking).

        Raises:
            LaunchRefused: they cannot be fetched.
        """
        if self.platform.jwks is not None:
            return self.platform.jwks
        now_s = wall_time_s()
        if self._jwks is not None and self._jwks[1] > now_s:
            return self._jwks[0]
        try:
            jwks = self._fetch(self.platform.jwks_url)
        except (OSError, ValueError) as err:
            raise LaunchRefused(f"the LMS's keys could not be had from {self.platform.jwks_url}: {err}") from err
        self._jwks = (jwks, now_s + JWKS_KEPT_S)
        return jwks

    def needs_fetch(self) -> bool:
        """Whether :meth:`keys` would fetch (the caller then runs it off its loop)."""
        return self.platform.jwks is None and (self._jwks is None or self._jwks[1] <= wall_time_s())

    def launch(self, id_token: str, state: str, cookie_state: str, jwks: dict[str, Any]) -> Launch:
        """Checks a launch whole; who it signs in.

        Args:
            id_token: The form's ``id_token``.
            state: The form's ``state``.
            cookie_state: The state the browser's cookie holds (empty: none).
            jwks: The LMS's keys (:meth:`keys`).

        Raises:
            LaunchRefused: any check fails; its message says which, in one line.
        """
        import jwt

        now_s = wall_time_s()
        self._forget(now_s)
        kept = self._states.pop(state, None) if state else None
        if kept is None:
            raise LaunchRefused("a launch whose state this tool did not give, or gave and saw used: start it again")
        if not cookie_state or not secrets.compare_digest(cookie_state, state):
            raise LaunchRefused("a launch whose state is not this browser's: start it again from the LMS")
        nonce, _ = kept
        try:
            header = jwt.get_unverified_header(id_token)
        except jwt.PyJWTError as err:
            raise LaunchRefused(f"the id_token is not a signed token: {err}") from err
        if header.get("alg") != "RS256":
            raise LaunchRefused(f"the id_token is signed with {_said(header.get('alg'))}; LTI 1.3 signs with RS256")
        key = _key_for(jwks, header.get("kid"))
        try:
            claims = jwt.decode(
                id_token,
                key=key,
                algorithms=["RS256"],
                audience=self.platform.client_id,
                issuer=self.platform.issuer,
                options={
                    "require": ["iss", "aud", "exp", "iat", "nonce", "sub"],
                    "verify_exp": False,
                    "verify_iat": False,
                    "verify_nbf": False,
                },  # fmt: skip - the times are checked below
            )
        except jwt.InvalidSignatureError as err:
            raise LaunchRefused("the id_token's signature is not the LMS's") from err
        except jwt.InvalidAudienceError as err:
            raise LaunchRefused("the id_token is for another tool (its audience is not this tool's client id)") from err
        except jwt.InvalidIssuerError as err:
            raise LaunchRefused("the id_token is from another LMS (its issuer is not this class's)") from err
        except jwt.PyJWTError as err:
            raise LaunchRefused(f"the id_token does not hold: {err}") from err
        _check_times(claims, now_s)
        audience = claims["aud"]
        if isinstance(audience, list) and len(audience) > 1 and claims.get("azp") != self.platform.client_id:
            raise LaunchRefused("the id_token names several audiences and its azp is not this tool's client id")
        if not isinstance(claims["nonce"], str) or not secrets.compare_digest(claims["nonce"], nonce):
            raise LaunchRefused("the id_token's nonce is not the one its login was given")
        if claims["nonce"] in self._used:
            raise LaunchRefused("the id_token was used already: start it again from the LMS")
        self._used[claims["nonce"]] = now_s + NONCE_S
        deployment = claims.get(_LTI + "deployment_id")
        if deployment not in self.platform.deployment_ids:
            raise LaunchRefused(f"the launch is from deployment {_said(deployment)}, not one of this class's")
        kind = claims.get(_LTI + "message_type")
        if kind != "LtiResourceLinkRequest":
            raise LaunchRefused(f"a {_said(kind)} message; a launch is an LtiResourceLinkRequest")
        if claims.get(_LTI + "version") != "1.3.0":
            raise LaunchRefused(f"LTI version {_said(claims.get(_LTI + 'version'))}; this tool speaks 1.3.0")
        link = claims.get(_LTI + "resource_link")
        if not isinstance(link, dict) or not link.get("id"):
            raise LaunchRefused("the launch names no resource link")
        roles = claims.get(_LTI + "roles")
        if not isinstance(roles, list):
            raise LaunchRefused("the launch gives no roles")
        if not isinstance(claims["sub"], str) or not claims["sub"].strip():
            raise LaunchRefused("the id_token names nobody (its sub is empty)")
        person = claims.get(_LTI + "lis")
        sourced = person.get("person_sourcedid", "") if isinstance(person, dict) else ""
        name = claims.get("name") or " ".join(str(claims.get(k, "")) for k in ("given_name", "family_name")).strip()
        return Launch(
            str(claims["sub"]),
            str(name or ""),
            str(sourced or ""),
            any(role in INSTRUCTOR_ROLES for role in roles),
            str(link["id"]),
        )

    def _forget(self, now_s: float) -> None:
        """Lets go of states and nonces past their time."""
        while self._states and next(iter(self._states.values()))[1] <= now_s:
            self._states.popitem(last=False)
        while self._used and next(iter(self._used.values())) <= now_s:
            self._used.popitem(last=False)


def _said(value: object) -> str:
    """A value a refusal says back: printable, short."""
    text = printable(repr(value) if not isinstance(value, str) else f"'{value}'")
    return text[:60] + ("..." if len(text) > 60 else "")


def _key_for(jwks: dict[str, Any], kid: object) -> Any:
    """The LMS's public key the token names (by ``kid``; the only one, if it names none)."""
    import jwt

    listed = jwks.get("keys") if isinstance(jwks, dict) else None
    keys = (
        [k for k in listed if isinstance(k, dict) and k.get("kty") == "RSA" and "d" not in k]
        if isinstance(listed, list)
        else []
    )
    chosen = [k for k in keys if k.get("kid") == kid] if kid is not None else keys[:1] if len(keys) == 1 else []
    if not chosen:
        raise LaunchRefused(f"the id_token is signed with key {_said(kid)}, which the LMS does not publish")
    try:
        return jwt.PyJWK(chosen[0], algorithm="RS256").key
    except jwt.PyJWTError as err:
        raise LaunchRefused(f"the LMS's key {_said(kid)} cannot be read: {err}") from err


def _check_times(claims: dict[str, Any], now_s: float) -> None:
    """The id_token's times against this machine's clock, within :data:`LEEWAY_S`."""
    for name in ("exp", "iat", "nbf"):
        value = claims.get(name)
        if name == "nbf" and value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise LaunchRefused(f"the id_token's {name} is not a time")
    if claims["exp"] + LEEWAY_S <= now_s:
        raise LaunchRefused("the id_token has expired: start it again from the LMS")
    if claims["iat"] - LEEWAY_S > now_s or claims.get("nbf", now_s) - LEEWAY_S > now_s:
        raise LaunchRefused("the id_token is from the future: is the LMS's clock or this machine's wrong?")


__all__ = [
    "Launch",
    "LaunchRefused",
    "LtiError",
    "LtiTool",
    "Platform",
    "ToolKey",
    "canvas_config",
    "read_platform",
    "tool_urls",
    "write_platform",
]

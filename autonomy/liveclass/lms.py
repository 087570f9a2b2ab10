"""The class's LMS beyond the sign-in: its roster read (Names and Roles), its marks sent back (Assignment and Grades).

LTI Advantage's services are plain HTTPS asked with an access token: the tool signs a JWT with its own
key (the one ``/lti/jwks`` publishes) and trades it at the LMS's token address for a token of the
scopes it needs (OAuth 2's client credentials, RFC 7523). With it:

- the *roster*: the course's members, page after page (``Link: <...>; rel="next"``), each a ``user_id``
  (the ``sub`` of their launches), roles, a name and the school's id. Learners are put on the class's
  roster, so that the class table shows them before they ever sign in; members the LMS calls inactive
  leave it (their work is kept);
- the *marks*: one line item per exercise (the link's own, when the LMS made one; else the course's
  line item whose ``resourceId`` is the exercise's, else one made with it, so never two), and a score
  for each student's hand-in, with a comment that links its feedback page.

Scores wait in the class's database (``lms_scores``) until the LMS has taken them: one waits per student
(a newer mark takes the place of one not yet sent), and each is sent once the LMS answers, in a
thread of its own (:class:`LmsLink`) that tries again later (1 s, doubling to :data:`RETRY_MOST_S`)
while the LMS cannot be reached. A score the LMS refuses (4xx) is kept as refused, with its reason, and
not sent again. The teacher's desk shows what was sent, what waits and what was refused.

Who a person is stays what the LMS first said: a ``sub`` is tied to one student for good, and a
student tied to one ``sub`` is never taken by another (a launch that tries is refused).
"""

from __future__ import annotations

import dataclasses
import datetime
import http.client
import json
import re
import secrets
import sqlite3
import threading
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Callable
from typing import Any

from autonomy.clock import Clock, wait_event, wall_time_s
from autonomy.liveclass.lti import INSTRUCTOR_ROLES, LaunchRefused, LtiTool
from autonomy.liveclass.store import ClassStore
from autonomy.views.lines import printable

#: The scopes the tool asks the LMS for.
SCOPE_MEMBERS = "https://purl.imsglobal.org/spec/lti-nrps/scope/contextmembership.readonly"
SCOPE_LINEITEM = "https://purl.imsglobal.org/spec/lti-ags/scope/lineitem"
SCOPE_SCORE = "https://purl.imsglobal.org/spec/lti-ags/scope/score"
#: Longest one request to the LMS may take, seconds; most bytes one answer may be; most pages of a roster.
REQUEST_TIMEOUT_S = 15.0
ANSWER_MOST_BYTES = 8 * 2**20
ROSTER_MOST_PAGES = 200
#: The longest a class's end waits for a request to the LMS under way, seconds.
STOP_WAIT_S = 1.0
#: The longest wait before the LMS is tried again while it cannot be reached, seconds (from 1 s, doubling).
RETRY_MOST_S = 30.0
#: Scores sent at once (an LMS far away answers each in a tenth of a second or more).
SENDS_AT_ONCE = 4
#: Most scores sent in one round (the rest in the next).
SENDS_PER_ROUND = 500
#: The class's settings that say what the LMS told of its course (from its launches) and what was found there.
COURSE = "lms.course"
MEMBERSHIPS_URL = "lms.memberships_url"
LINEITEMS_URL = "lms.lineitems_url"
LINK_LINEITEM_URL = "lms.link_lineitem_url"
LINEITEM_URL = "lms.lineitem_url"
ROSTER_READ = "lms.roster_read"
#: The tag of the line items the tool makes (so that the teacher sees whose they are).
TAG = "autonomy"
#: The longest a person's id or name is kept.
MOST_ID_CHARS = 300

_MEMBERS_TYPE = "application/vnd.ims.lti-nrps.v2.membershipcontainer+json"
_LINEITEMS_TYPE = "application/vnd.ims.lis.v2.lineitemcontainer+json"
_LINEITEM_TYPE = "application/vnd.ims.lis.v2.lineitem+json"
_SCORE_TYPE = "application/vnd.ims.lis.v1.score+json"
_NEXT = re.compile(r'<([^>]+)>\s*;\s*rel="?next"?')


class LmsDown(Exception):
    """The LMS cannot be reached, or answered that it cannot answer now (5xx, 429): tried again later."""


class LmsRefused(Exception):
    """The LMS refused what was asked (4xx but 429, or a redirect), or answered with what is not what LTI says.

    Attributes:
        status: The LMS's answer's status (0: not an answer's: what it answered was not LTI's).
    """

    def __init__(self, message: str, status: int = 0) -> None:
        super().__init__(message)
        self.status = status


#: A score the LMS refused for what it holds (not for the link's token or line item): kept refused, not sent again.
SCORE_REFUSALS = (400, 409, 413, 422)
#: The longest ``sub`` taken (OpenID Connect's: 255 ASCII characters).
MOST_SUBJECT_CHARS = 255


@dataclasses.dataclass(frozen=True)
class Member:
    """One member of the course, as the LMS's roster gives them."""

    subject: str
    name: str
    roster_id: str
    instructor: bool
    active: bool


@dataclasses.dataclass(frozen=True)
class Score:
    """A score waiting to be sent."""

    number: int
    student: str
    subject: str
    given: float
    maximum: float
    comment: str
    at: str


def student_id(subject: str, roster_id: str) -> str:
    """The class's id of a person the LMS names: the school's id, as a roster holds it; else the LMS's own, apart."""
    return printable(roster_id.strip() or f"lms:{subject}")[:MOST_ID_CHARS]


# ---------------------------------------------------------------------- the people, in the class's database


def admit(store: ClassStore, subject: str, student: str, name: str) -> str:
    """Puts a learner the LMS launched on the roster; their student id (the one their ``sub`` was first tied to).

    Raises:
        LaunchRefused: the student id is another LMS person's already.
    """
    name = printable(name)[:MOST_ID_CHARS]

    def work(db: sqlite3.Connection) -> str:
        taken = _tie(db, subject, student, name, instructor=False, active=True)
        if taken is None:
            raise LaunchRefused(f"the class's student {student!r} is another LMS person's: ask the teacher")
        return taken

    return store.transact(work)


def _tie(db: sqlite3.Connection, subject: str, student: str, name: str, instructor: bool, active: bool) -> str | None:
    """Ties a person to the class (a learner to a student, on the roster while active); their id, None if taken."""
    row = db.execute("SELECT student FROM lms_people WHERE sub = ?", (subject,)).fetchone()
    name = printable(name)[:MOST_ID_CHARS]
    if instructor:
        if row is None:
            db.execute(
                "INSERT INTO lms_people (sub, name, instructor, active) VALUES (?, ?, 1, ?)", (subject, name, active)
            )
        else:
            db.execute(
                "UPDATE lms_people SET name = ?, instructor = 1, active = ? WHERE sub = ?", (name, active, subject)
            )
        return ""
    if row is not None and row[0]:
        student = row[0]  # who they are stays what it was first
    elif db.execute("SELECT 1 FROM lms_people WHERE student = ?", (student,)).fetchone():
        return None
    db.execute(
        "INSERT INTO students (id, name, code_sha256, on_roster) VALUES (?, ?, ?, ?) ON CONFLICT(id) DO UPDATE SET "
        "on_roster = excluded.on_roster, name = CASE WHEN excluded.name != '' THEN excluded.name ELSE name END",
        (student, name or student, "lms " + secrets.token_hex(16), int(active)),
    )  # a code nobody knows: they sign in from the LMS (the teacher may give them one with class codes)
    db.execute(
        "INSERT INTO lms_people (sub, student, name, instructor, active) VALUES (?, ?, ?, 0, ?) ON CONFLICT(sub) DO "
        "UPDATE SET student = excluded.student, name = excluded.name, instructor = 0, active = excluded.active",
        (subject, student, name, int(active)),
    )
    return student


@dataclasses.dataclass(frozen=True)
class RosterRead:
    """What reading the LMS's roster did."""

    learners: int
    instructors: int
    left: int
    clashes: list[str]


def take_roster(store: ClassStore, members: list[Member]) -> RosterRead:
    """Puts the LMS's roster in the class: its active learners on the roster, its inactive ones off it."""
    clashes: list[str] = []
    counts = [0, 0, 0]

    def work(db: sqlite3.Connection) -> None:
        for member in members:
            student = student_id(member.subject, member.roster_id)
            taken = _tie(db, member.subject, student, member.name, member.instructor, member.active)
            if taken is None:
                clashes.append(student)
            else:
                counts[1 if member.instructor else 0 if member.active else 2] += 1

    store.transact(work)
    return RosterRead(counts[0], counts[1], counts[2], clashes)


def instructors(store: ClassStore) -> list[str]:
    """The names of the course's instructors the LMS gave."""
    return [row[0] for row in store.read("SELECT name FROM lms_people WHERE instructor = 1 AND active = 1")]


def subject_of(store: ClassStore, student: str) -> str:
    """The LMS's id of a student (empty: the LMS does not know them)."""
    rows = store.read("SELECT sub FROM lms_people WHERE student = ?", (student,))
    return rows[0][0] if rows else ""


# ---------------------------------------------------------------------- the scores, in the class's database


def queue_score(store: ClassStore, student: str, given: float, maximum: float, comment: str) -> bool:
    """Puts a student's mark in the queue for the LMS (in place of one of theirs not yet sent); False: not the LMS's."""
    subject = subject_of(store, student)
    if not subject:
        return False
    last = store.read(
        "SELECT given, maximum, comment FROM lms_scores WHERE student = ? AND refused = '' ORDER BY id DESC LIMIT 1",
        (student,),
    )
    if last and tuple(last[0]) == (given, maximum, comment):
        return True  # the LMS has it, or will: a launch or a new reading does not send it again
    at = datetime.datetime.fromtimestamp(wall_time_s(), datetime.UTC).isoformat(timespec="milliseconds")
    store.write(
        [
            ("DELETE FROM lms_scores WHERE student = ? AND sent = '' AND refused = ''", (student,)),
            ("INSERT INTO lms_scores (student, sub, given, maximum, comment, at) VALUES (?, ?, ?, ?, ?, ?)",
             (student, subject, given, maximum, comment, at)),
        ]
    )  # fmt: skip
    return True


def waiting(store: ClassStore, most: int = SENDS_PER_ROUND) -> list[Score]:
    """The scores waiting, the oldest first."""
    rows = store.read(
        "SELECT id, student, sub, given, maximum, comment, at FROM lms_scores WHERE sent = '' AND refused = '' "
        "ORDER BY id LIMIT ?",
        (most,),
    )
    return [Score(*row) for row in rows]


def scores_said(store: ClassStore, most: int = 30) -> dict[str, Any]:
    """What the desk shows of the scores: how many were sent, wait and were refused, and the last ones."""
    (sent, waits, refused), = store.read(
        "SELECT COUNT(*) FILTER (WHERE sent != ''), COUNT(*) FILTER (WHERE sent = '' AND refused = ''), "
        "COUNT(*) FILTER (WHERE refused != '') FROM lms_scores"
    )  # fmt: skip
    rows = store.read(
        "SELECT s.student, st.name, s.given, s.maximum, s.at, s.sent, s.refused FROM lms_scores s "
        "JOIN students st ON st.id = s.student ORDER BY s.id DESC LIMIT ?",
        (most,),
    )
    last = [
        {"id": sid, "name": name, "given": given, "maximum": maximum, "marked": at, "sent": done, "refused": why}
        for sid, name, given, maximum, at, done, why in rows
    ]
    return {"sent": sent, "waiting": waits, "refused": refused, "last": last}


# ---------------------------------------------------------------------- the LMS's services, over HTTPS


Fetch = Callable[[urllib.request.Request, float], tuple[int, dict[str, str], bytes]]


class _NoRedirect(urllib.request.HTTPRedirectHandler):
    """A redirect is not followed (a score posted is not a GET elsewhere, nor is the token sent there): answered."""

    def redirect_request(self, *_: Any, **__: Any) -> None:
        return None


_OPENER = urllib.request.build_opener(_NoRedirect)


def _fetch(request: urllib.request.Request, timeout_s: float) -> tuple[int, dict[str, str], bytes]:
    """One request: status, headers (lower-case names), body (at most :data:`ANSWER_MOST_BYTES`); no redirect."""
    try:
        with _OPENER.open(request, timeout=timeout_s) as answer:
            body = answer.read(ANSWER_MOST_BYTES + 1)
            status, headers = answer.status, {k.lower(): v for k, v in answer.getheaders()}
    except urllib.error.HTTPError as err:
        body = err.read(4096) if err.fp is not None else b""
        return err.code, {k.lower(): v for k, v in err.headers.items()}, body
    except (OSError, http.client.HTTPException) as err:  # unreachable, refused, cut short, too slow
        why = err.reason if isinstance(err, urllib.error.URLError) else err
        why = why.strerror or why if isinstance(why, OSError) else why  # "Connection refused", not its repr
        raise LmsDown(
            f"{urllib.parse.urlsplit(request.full_url).netloc}: {str(why).lower() or type(err).__name__}"
        ) from err
    if len(body) > ANSWER_MOST_BYTES:
        raise LmsRefused(f"an answer of more than {ANSWER_MOST_BYTES:,} bytes")
    return status, headers, body


class LmsServices:
    """The LMS's roster and gradebook, asked with an access token the tool's key earns (blocking; thread-safe).

    Args:
        tool: The class's LTI tool (its LMS and its key).
        fetch: Sends one request (tests give their own).
    """

    def __init__(self, tool: LtiTool, fetch: Fetch = _fetch) -> None:
        self.platform, self._key, self._send = tool.platform, tool.key, fetch
        self._tokens: dict[str, tuple[str, float]] = {}
        self._lock = threading.Lock()

    def _token(self, scope: str) -> str:
        """An access token of ``scope``: kept while it lasts, else asked for."""
        import jwt

        with self._lock:
            kept = self._tokens.get(scope)
        now_s = wall_time_s()
        if kept is not None and kept[1] > now_s:
            return kept[0]
        if not self.platform.token_url:
            raise LmsRefused("the LMS's token URL is not given: autonomy class lti-config --token-url")
        claims = {"iss": self.platform.client_id, "sub": self.platform.client_id, "aud": self.platform.token_url,
                  "iat": int(now_s), "exp": int(now_s) + 300, "jti": secrets.token_urlsafe(18)}  # fmt: skip
        assertion = jwt.encode(claims, self._key.private, algorithm="RS256", headers={"kid": self._key.kid})
        form = {
            "grant_type": "client_credentials",
            "client_assertion_type": "urn:ietf:params:oauth:client-assertion-type:jwt-bearer",
            "client_assertion": assertion,
            "scope": scope,
        }
        request = urllib.request.Request(
            self.platform.token_url, data=urllib.parse.urlencode(form).encode(), method="POST",
            headers={"Content-Type": "application/x-www-form-urlencoded", "Accept": "application/json"},
        )  # fmt: skip
        status, _, body = self._send(request, REQUEST_TIMEOUT_S)
        _said_ok(status, body, "an access token")
        answer = _json_of(body, "the access token's answer")
        token, lasts = answer.get("access_token"), answer.get("expires_in", 3600)
        if not isinstance(token, str) or not token or isinstance(lasts, bool) or not isinstance(lasts, (int, float)):
            raise LmsRefused("the LMS's access token answer holds no token")
        with self._lock:
            self._tokens[scope] = (token, now_s + max(0.0, min(float(lasts), 86400.0) - 60.0))
        return token

    def _ask(self, method: str, url: str, scope: str, accept: str, body: Any = None, kind: str = "") -> tuple[
        dict[str, str], bytes]:  # fmt: skip
        """One request with a token; once again with a new token if the LMS says the token lapsed (401)."""
        if urllib.parse.urlsplit(url).scheme not in ("https", "http"):
            raise LmsRefused(f"the LMS gave an address that is not one: {printable(url)[:80]}")
        for again in (False, True):
            headers = {"Authorization": f"Bearer {self._token(scope)}", "Accept": accept}
            data = None
            if body is not None:
                data, headers["Content-Type"] = json.dumps(body).encode(), kind
            status, answer_headers, answer = self._send(
                urllib.request.Request(url, data=data, method=method, headers=headers), REQUEST_TIMEOUT_S
            )
            if status == 401 and not again:
                with self._lock:
                    self._tokens.pop(scope, None)
                continue
            _said_ok(status, answer, f"{method} {urllib.parse.urlsplit(url).path}")
            return answer_headers, answer
        raise AssertionError("unreachable")

    def members(self, url: str) -> list[Member]:
        """The course's members, every page of them."""
        people: list[Member] = []
        for _ in range(ROSTER_MOST_PAGES):
            headers, body = self._ask("GET", url, SCOPE_MEMBERS, _MEMBERS_TYPE)
            listed = _json_of(body, "the roster").get("members")
            if not isinstance(listed, list):
                raise LmsRefused("the LMS's roster holds no members")
            people += [member for entry in listed if (member := _member(entry)) is not None]
            found = _NEXT.search(headers.get("link", ""))
            if found is None:
                return people
            url = urllib.parse.urljoin(url, found[1])
        raise LmsRefused(f"the LMS's roster is more than {ROSTER_MOST_PAGES} pages")

    def line_item(self, lineitems_url: str, resource_id: str, label: str, maximum: float) -> str:
        """The course's line item of ``resource_id``: found (never made twice), else made; its address."""
        url = _with_query(lineitems_url, {"resource_id": resource_id, "limit": "100"})
        for _ in range(ROSTER_MOST_PAGES):
            headers, body = self._ask("GET", url, SCOPE_LINEITEM, _LINEITEMS_TYPE)
            try:
                items = json.loads(body) if body.strip() else []
            except (UnicodeDecodeError, ValueError) as err:
                raise LmsRefused("the LMS's line items are not JSON") from err
            if not isinstance(items, list):
                raise LmsRefused("the LMS's line items are not a list")
            for item in items:  # the LMS's filter is not trusted: each is checked
                if isinstance(item, dict) and item.get("resourceId") == resource_id and isinstance(item.get("id"), str):
                    return item["id"]
            found = _NEXT.search(headers.get("link", ""))
            if found is None:
                break
            url = urllib.parse.urljoin(url, found[1])
        made = {"scoreMaximum": maximum, "label": label, "resourceId": resource_id, "tag": TAG}
        _, body = self._ask("POST", lineitems_url, SCOPE_LINEITEM, _LINEITEM_TYPE, made, _LINEITEM_TYPE)
        item = _json_of(body, "the line item made")
        if not isinstance(item.get("id"), str):
            raise LmsRefused("the LMS made a line item and gave no address of it")
        return item["id"]

    def send(self, lineitem_url: str, score: Score) -> None:
        """Sends one score to the line item."""
        parts = urllib.parse.urlsplit(lineitem_url)
        url = urllib.parse.urlunsplit(parts._replace(path=parts.path.rstrip("/") + "/scores"))
        body = {
            "userId": score.subject,
            "scoreGiven": score.given,
            "scoreMaximum": score.maximum,
            "comment": score.comment,
            "timestamp": score.at,
            "activityProgress": "Completed",
            "gradingProgress": "FullyGraded",
        }
        self._ask("POST", url, SCOPE_SCORE, "application/json", body, _SCORE_TYPE)


def _said_ok(status: int, body: bytes, what: str) -> None:
    if status == 429 or status >= 500:
        raise LmsDown(f"the LMS could not answer {what} now ({status})")
    if not 200 <= status < 300:
        said = printable(body[:160].decode("utf-8", "replace")).strip()
        raise LmsRefused(f"the LMS refused {what} ({status}{': ' + said if said else ''})", status)


def _json_of(body: bytes, what: str) -> dict[str, Any]:
    try:
        data = json.loads(body)
    except (UnicodeDecodeError, ValueError) as err:
        raise LmsRefused(f"{what} is not JSON") from err
    if not isinstance(data, dict):
        raise LmsRefused(f"{what} is not a JSON object")
    return data


def _with_query(url: str, more: dict[str, str]) -> str:
    parts = urllib.parse.urlsplit(url)
    query = urllib.parse.parse_qsl(parts.query) + list(more.items())
    return urllib.parse.urlunsplit(parts._replace(query=urllib.parse.urlencode(query)))


def _member(entry: object) -> Member | None:
    """A roster's entry as a member; None: not one (no user id)."""
    if not isinstance(entry, dict) or not isinstance(entry.get("user_id"), str) or not entry["user_id"].strip():
        return None
    if len(entry["user_id"]) > MOST_SUBJECT_CHARS:
        return None  # not OpenID Connect's: never cut to another's
    roles = entry.get("roles") if isinstance(entry.get("roles"), list) else []
    name = entry.get("name") or " ".join(str(entry.get(k) or "") for k in ("given_name", "family_name")).strip()
    sourced = entry.get("lis_person_sourcedid")
    return Member(
        entry["user_id"],
        printable(name if isinstance(name, str) else "")[:MOST_ID_CHARS],
        sourced if isinstance(sourced, str) else "",
        any(role in INSTRUCTOR_ROLES for role in roles),
        entry.get("status", "Active") == "Active",
    )


# ---------------------------------------------------------------------- the link: one thread, all of the LMS's I/O


class LmsLink:
    """Reads the roster when asked, and sends the waiting scores, in a thread of its own.

    Args:
        store: The class's database.
        services: The LMS's services.
        resource_id: The exercise's line item's ``resourceId``; label, maximum: its label and most points.
        clock: Whose time the waits are in.
        changed: Called (from the link's thread) when the roster or the scores changed.
    """

    def __init__(
        self, store: ClassStore, services: LmsServices, resource_id: str, label: str, maximum: float, clock: Clock,
        changed: Callable[[], None] = lambda: None,
    ) -> None:  # fmt: skip
        self.store, self.services, self.clock, self._changed = store, services, clock, changed
        self._item = (resource_id, label, maximum)
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._roster_wanted = False
        self._retry_s = 0.0
        self._next_try_s = 0.0
        #: What the link last could not do (shown on the desk), and what reading the roster last did.
        self.problem = ""
        self.roster: dict[str, Any] = {}
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        """Starts the link's thread."""
        self._thread = threading.Thread(target=self._run, name="autonomy-lms-link", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stops the link's thread, waiting at most :data:`STOP_WAIT_S` for a request under way.

        A class's end is not held up by a slow LMS: a score whose answer did not come stays waiting, and is sent
        at the class's next start (with the same timestamp, which the LMS takes as the same score).
        """
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join(timeout=STOP_WAIT_S)

    def nudge(self, roster: bool = False, now: bool = False) -> None:
        """Something to do: a score queued (and the roster to read, if ``roster``; at once, if ``now``)."""
        self._roster_wanted = self._roster_wanted or roster
        if now:
            self._next_try_s = 0.0
        self._wake.set()

    def send_again(self) -> int:
        """The refused scores waiting again (the teacher mended what the LMS refused them for); how many."""
        again = self.store.read("SELECT COUNT(*) FROM lms_scores WHERE refused != ''")[0][0]
        self.store.write(
            [
                (
                    "UPDATE lms_scores SET refused = '' WHERE refused != '' AND id IN (SELECT MAX(id) FROM lms_scores "
                    "GROUP BY student)",
                    (),
                ),
                ("DELETE FROM lms_scores WHERE refused != ''", ()),
            ]
        )  # fmt: skip - each student's newest again; older refused ones are superseded
        self.nudge(now=True)
        return again

    def _run(self) -> None:
        while not self._stop.is_set():
            self._wake.clear()
            try:
                delay_s = self.round(self.clock.now())
            except Exception as err:  # noqa: BLE001 - the link keeps going, and the desk says why it could not
                self._said(f"the marks could not be sent ({type(err).__name__}: {printable(str(err))[:160]})")
                delay_s = RETRY_MOST_S
            if delay_s > 0:
                wait_event(self._wake, delay_s)

    def round(self, now_s: float) -> float:
        """Does what is due now (the roster if asked, then the waiting scores); how long until it tries again.

        0 when more waits at once; a long while when nothing does (a nudge wakes it).
        """
        if now_s < self._next_try_s:
            return self._next_try_s - now_s
        try:
            if self._roster_wanted:
                self._read_roster()
            more = self._send_waiting()
        except LmsDown as err:
            self._retry_s = min(RETRY_MOST_S, max(1.0, self._retry_s * 2))
            self._next_try_s = now_s + self._retry_s
            self._said(f"the LMS cannot be reached ({err}); tried again in {self._retry_s:g} s")
            return self._retry_s
        except LmsRefused as err:
            self._said(str(err))
            self._roster_wanted = False
            return RETRY_MOST_S * 10
        self._retry_s = 0.0
        self._said("")
        return 0.0 if more else RETRY_MOST_S * 10

    def _said(self, problem: str) -> None:
        if problem != self.problem:
            self.problem = problem
            self._changed()

    def _read_roster(self) -> None:
        url = self.store.setting(MEMBERSHIPS_URL)
        self._roster_wanted = False
        if not url:
            raise LmsRefused("the LMS gave no roster address yet: the teacher opens the class's link in the LMS")
        read = take_roster(self.store, self.services.members(url))
        self.roster = {"learners": read.learners, "instructors": read.instructors, "left": read.left,
                       "clashes": read.clashes[:10], "read": wall_time_s()}  # fmt: skip
        self.store.set_setting(ROSTER_READ, json.dumps(self.roster))
        self._changed()

    def _line_item(self) -> str:
        """The exercise's line item: kept, the link's own, or found or made in the course (kept from then on)."""
        kept = self.store.setting(LINK_LINEITEM_URL) or self.store.setting(LINEITEM_URL)
        if kept:
            return kept
        items = self.store.setting(LINEITEMS_URL)
        if not items:
            raise LmsRefused("the LMS gave no gradebook address yet: the teacher opens the class's link in the LMS")
        found = self.services.line_item(items, *self._item)
        self.store.set_setting(LINEITEM_URL, found)
        return found

    def _send_waiting(self) -> bool:
        """Sends the waiting scores (some at once); whether more wait."""
        scores = waiting(self.store)
        if not scores:
            return False
        item = self._line_item()
        outcomes = _in_daemons(lambda score: self._send_one(item, score), scores, SENDS_AT_ONCE)
        self._changed()
        for outcome in outcomes:
            if isinstance(outcome, LmsDown):
                raise outcome
        for outcome in outcomes:  # the link's, not the score's: its token, its scope, its line item
            if isinstance(outcome, LmsRefused):
                if outcome.status in (404, 410):  # the line item is gone (the column deleted): found or made anew
                    for key in (LINK_LINEITEM_URL, LINEITEM_URL):
                        if self.store.setting(key) == item:
                            self.store.set_setting(key, "")
                raise outcome
        return len(scores) == SENDS_PER_ROUND

    def _send_one(self, item: str, score: Score) -> Exception | None:
        try:
            self.services.send(item, score)
        except LmsDown as err:
            return err
        except LmsRefused as err:
            if err.status not in SCORE_REFUSALS:
                return err  # the link's problem: the score waits
            self.store.write([("UPDATE lms_scores SET refused = ? WHERE id = ?", (str(err)[:300], score.number))])
            return None
        sent = datetime.datetime.fromtimestamp(wall_time_s(), datetime.UTC).isoformat(timespec="seconds")
        self.store.write([("UPDATE lms_scores SET sent = ? WHERE id = ?", (sent, score.number))])
        return None


def _in_daemons(work: Callable[[Score], Exception | None], scores: list[Score], width: int) -> list[Exception | None]:
    """``work`` of each score, ``width`` at once, in daemon threads: a process that ends waits for no LMS's answer.

    (A thread pool's workers are joined at the interpreter's exit: a class ended by Ctrl-C would wait out a
    request to an LMS that never answers.)
    """
    outcomes: list[Exception | None] = [None] * len(scores)
    queue = iter(enumerate(scores))
    lock = threading.Lock()

    def run() -> None:
        while True:
            with lock:
                taken = next(queue, None)
            if taken is None:
                return
            outcomes[taken[0]] = work(taken[1])

    threads = [
        threading.Thread(target=run, name="autonomy-lms-send", daemon=True) for _ in range(min(width, len(scores)))
    ]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    return outcomes


__all__ = [
    "LmsDown",
    "LmsLink",
    "LmsRefused",
    "LmsServices",
    "Member",
    "RosterRead",
    "Score",
    "admit",
    "queue_score",
    "scores_said",
    "student_id",
    "take_roster",
    "waiting",
]

"""The console's pages. Every route but the login page requires a signed-in experimenter.

Participants reach the console through nothing: their token is not a login,
and console URLs name participants by code, never by token.
"""

from __future__ import annotations

import re
import unicodedata
from urllib.parse import urlsplit

from flask import (
    Blueprint,
    Response,
    abort,
    current_app,
    flash,
    jsonify,
    redirect,
    render_template,
    request,
    send_file,
    url_for,
)
from flask import (
    session as cookie_session,
)
from flask.typing import ResponseReturnValue
from flask_login import LoginManager, current_user, login_required, login_user, logout_user
from markupsafe import Markup, escape
from sqlalchemy import select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from hcss.platform.console import forms
from hcss.platform.console.audit import audit_entries
from hcss.platform.console.factor_enrolment import confirm, offer, offered_secret
from hcss.platform.console.interventions import (
    ConsoleError,
    available_actions,
    change_participant_state,
    reinstate,
    set_pilot,
    study_status,
)
from hcss.platform.console.link_limit import LinkLimitReached, require_allowance
from hcss.platform.console.login_sessions import end_sessions, experimenter_for_cookie
from hcss.platform.console.participant_table import FLAGS, progress_json, progress_page
from hcss.platform.console.participants import (
    USABLE,
    batch_of_form,
    batches,
    create_participants,
    link_rows,
    links_csv,
    participant_link,
    participants_by_code,
)
from hcss.platform.console.presence import CONNECTED_WITHIN_S
from hcss.platform.console.second_factor import has_second_factor
from hcss.platform.console.signin import answer_sign_in
from hcss.platform.console.skipping import skip_step, skip_targets
from hcss.platform.console.withdrawal import WithdrawalError, withdraw
from hcss.platform.db import database, get_session, session_now
from hcss.platform.live.service import LiveTrials, live_trials
from hcss.platform.models import AuditRecord, ConsoleAction, Experimenter, Participant
from hcss.platform.models.participant_state import participant_state
from hcss.platform.models.pilots import is_pilot
from hcss.platform.study.enrolment import current_enrolment
from hcss.platform.study.files import study_names
from hcss.platform.study.outcomes import Outcomes, outcomes
from hcss.platform.study.recruitment import Enrolled, enrolled
from hcss.platform.study.studyfile import StudyFileError, load_study
from hcss.platform.study.timeouts import time_out_abandoned
from hcss.platform.study.versions import study_problems

bp = Blueprint("console", __name__, url_prefix="/console", static_folder="static")
login_manager = LoginManager()
login_manager.login_view = "console.login"
login_manager.login_message = "Sign in to use the console."
login_manager.session_protection = "strong"
CODE = re.compile(r"[A-Z0-9]{1,32}")
#: The longest page a sign-in redirect names in `next`: its Location header must fit a
#: proxy's buffer for response headers (nginx: 4 kB), or the proxy answers 502.
NEXT_MAX = 1024


@login_manager.unauthorized_handler
def _sign_in_first() -> ResponseReturnValue:
    """Flask-Login's redirect to the sign-in page, its `next` the page asked for while short.

    A link with a long query (a 5,000-digit code) gave a Location header nginx refused
    (502); such a page is named by its path alone, or not at all.
    """
    flash(login_manager.login_message, login_manager.login_message_category)
    page = request.full_path.removesuffix("?")
    if len(page) > NEXT_MAX:
        page = request.path
    if len(page) > NEXT_MAX:
        return redirect(url_for("console.login"))
    return redirect(url_for("console.login", next=page))


@bp.record_once
def _init_login(state) -> None:
    login_manager.init_app(state.app)


@bp.app_context_processor
def _export_studies() -> dict[str, object]:
    """The console bar's export choice: the studies that have participants (read when shown)."""

    def export_studies() -> list[str]:
        from hcss.platform.export.selection import present_studies

        return present_studies(get_session())

    return {"export_studies": export_studies}


@bp.app_template_filter("highlight")
def _highlight(text: str | None, search: str) -> Markup:
    """`text` escaped, each search word found in it marked (<mark>), case aside."""
    text = text or ""
    words = [re.escape(word) for word in search.split() if word]
    if not words:
        return escape(text)
    pieces = re.split(f"({'|'.join(words)})", text, flags=re.IGNORECASE)
    return Markup("").join(
        Markup("<mark>{}</mark>").format(piece) if index % 2 else escape(piece)
        for index, piece in enumerate(pieces)
    )


@login_manager.user_loader
def _load_experimenter(user_id: str) -> Experimenter | None:
    return experimenter_for_cookie(get_session(), user_id)


def _live() -> LiveTrials:
    return live_trials()


def _participant(code: str) -> Participant:
    found = get_session().scalars(select(Participant).where(Participant.code == code)).first()
    if found is None:
        abort(404)
    return found


def _safe_next(target: str | None) -> str:
    """Only a console path: a login link must not redirect anywhere else. A control or
    line-separator character (CR/LF in a mailed link) makes it no page: werkzeug refuses
    such a Location, and the right password answered 500."""
    if (
        target
        and target.startswith("/console/")
        and not urlsplit(target).netloc
        and not any(unicodedata.category(char) in ("Cc", "Zl", "Zp") for char in target)
    ):
        return target
    return url_for("console.index")


@bp.route("/login", methods=["GET", "POST"])
def login():
    form = forms.LoginForm()
    if form.validate_on_submit():
        return answer_sign_in(form, _safe_next(request.args.get("next")))
    return render_template("console/login.html", form=form)


@bp.post("/logout")
@login_required
def logout():
    if not forms.ActionForm().validate_on_submit():
        abort(400)
    end_sessions(get_session(), current_user.id)  # every cookie issued so far stops working
    logout_user()
    cookie_session.clear()
    return redirect(url_for("console.login"))


@bp.route("/second-factor", methods=["GET", "POST"])
@login_required
def second_factor() -> ResponseReturnValue:
    """Enrol (or replace) the signed-in experimenter's second factor: scan, confirm, keep
    the recovery codes (hcss.platform.console.factor_enrolment)."""
    form = forms.SecondFactorForm()
    key = current_app.config["SECRET_KEY"]
    posted = request.method == "POST"
    carried = offered_secret(current_user, form.offer.data or "", key) if posted else None
    error = None
    if form.validate_on_submit():
        if carried is None:
            error = "That QR code is too old. Scan this new one and type its code."
        else:
            done = confirm(database(), current_user.id, carried, form.code.data)
            if done is not None:
                login_user(done.account)  # this browser stays in; the others are signed out
                return render_template("console/second_factor_done.html", enrolment=done.enrolment)
            error = (
                "That is not the code the app shows for this QR code. Type the one it shows now."
            )
    elif posted:
        error = "Type the six-digit code the app shows."
    form.code.data = ""
    return _factor_page(form, offer(current_user, key, carried), error)


def _factor_page(form: forms.SecondFactorForm, offered, error: str | None) -> ResponseReturnValue:
    form.offer.data = offered.signed
    status = 400 if error else 200
    page = render_template(
        "console/second_factor.html",
        form=form,
        offered=offered,
        error=error,
        enrolled=has_second_factor(current_user),
    )
    return page, status


@bp.get("/")
@login_required
def index() -> str:
    session = get_session()
    audits = session.scalars(select(AuditRecord).order_by(AuditRecord.id.desc()).limit(20)).all()
    return render_template(
        "console/index.html",
        table=_table_page(),
        study_problems=study_problems(session),
        create_form=forms.CreateParticipantsForm(),
        action_form=forms.ActionForm(),
        audits=audit_entries(audits),
        recruitment=recruitment_targets(session),
        outcomes=link_outcomes(session),
        bulk_actions=BULK_ACTIONS,
        action_labels=ACTION_LABELS,
        connected_within_s=CONNECTED_WITHIN_S,
        poll_s=float(current_app.config.get("CONSOLE_POLL_S", 2.0)),
    )


def recruitment_targets(session: Session) -> list[Enrolled]:
    """Each study with a study link and a recruitment target or time-outs: how far it is."""
    studies = []
    for name in study_names():
        try:
            study = load_study(name)
        except StudyFileError:  # a broken file is reported when it is used, not here
            continue
        limits = study.online.target or study.online.cell_target or study.timeouts.active
        if study.online.link and limits:
            studies.append(enrolled(session, study))
    return studies


def link_outcomes(session: Session) -> list[Outcomes]:
    """Each study with a study link that someone has come through: its visitors by outcome."""
    found = []
    for name in study_names():
        try:
            study = load_study(name)
        except StudyFileError:
            continue
        if study.online.link:
            counted = outcomes(session, study)
            if counted.total:
                found.append(counted)
    return found


@bp.get("/progress.json")
@login_required
def progress() -> Response:
    return jsonify(progress_json(_table_page()))


def _table_page():
    """The page of the live table that ``?page=N&hide=pilot,bot,demo&q=SEARCH`` asks for."""
    page = request.args.get("page", "1")
    hide = frozenset(flag for flag in request.args.get("hide", "").split(",") if flag in FLAGS)
    number = int(page) if page.isascii() and page.isdigit() and len(page) < 7 else 1
    session = get_session()
    if time_out_abandoned(session, session_now(session)):  # the study files' [timeouts]
        session.commit()
    return progress_page(
        session, _live().now(), page=number, hide=hide, search=request.args.get("q", "")
    )


@bp.post("/participants")
@login_required
def create():
    form = forms.CreateParticipantsForm()
    if not form.validate_on_submit():
        for field, errors in form.errors.items():
            flash(f"{field}: {'; '.join(errors)}")
        return redirect(url_for("console.index")), 303
    key = form.form_key.data or None
    if key is not None and (answer := _answer_to_a_repeat(key, form.study.data)) is not None:
        return answer
    try:
        require_allowance(
            get_session(),
            current_user,
            form.count.data,
            _live().now(),
            current_app.config.get("LINKS_PER_EXPERIMENTER"),
        )
    except LinkLimitReached as reached:
        get_session().commit()  # the audit row
        flash(reached.message)
        return index(), 429, {"Retry-After": str(reached.retry_after_s)}
    try:
        made = create_participants(
            get_session(),
            count=form.count.data,
            pilot=form.pilot.data,
            cell=form.cell.data,
            experimenter=current_user,
            now=_live().now(),
            study=form.study.data,
            form_key=key,
        )
        codes = tuple(participant.code for participant in made)
        get_session().commit()
    except ConsoleError as error:
        get_session().rollback()
        flash(str(error))
        return redirect(url_for("console.index")), 303
    except IntegrityError:
        # The same form, carried out by a request that committed first (a double click
        # that reached the server twice): its batch is the answer, this one is not stored.
        # Any other conflict is not a repeat, and is not answered as one.
        get_session().rollback()
        answer = None if key is None else _answer_to_a_repeat(key, form.study.data)
        if answer is None:
            raise
        return answer
    return _batch_made(codes, form.study.data, again=False)


def _answer_to_a_repeat(key: str, study: str | None) -> ResponseReturnValue | None:
    """The answer to a Create form already carried out: the batch it made (None: it has
    not been); a 409 for a key another account's form carried."""
    try:
        made_before = batch_of_form(get_session(), key, current_user)
    except ConsoleError as error:
        flash(str(error))
        return index(), 409
    return None if made_before is None else _batch_made(made_before, study, again=True)


def _batch_made(codes: tuple[str, ...], study: str | None, *, again: bool) -> ResponseReturnValue:
    """Where a Create leads: the one participant's page, or the batch's links; a form sent
    again is told so and led to the batch its first sending made."""
    if again:
        flash("this form was already sent, and nothing new was created: here is what it made")
    if not codes:
        return redirect(url_for("console.index")), 303
    if len(codes) == 1:
        if not again:
            flash(f"created {codes[0]}")
        return redirect(url_for("console.participant", code=codes[0])), 303
    if not again:
        flash(f"created {len(codes)} participants in study {study}")
    return redirect(url_for("console.links", codes=",".join(codes))), 303


MAX_LINKS = 500


def _named_participants() -> list[Participant]:
    """The participants in ``?codes=P1,P2`` (a batch just created, or any selection);
    without codes, every participant's, newest first, so links can be handed out again."""
    raw = request.args.get("codes", "")
    codes = [code.strip() for code in raw.split(",") if code.strip()]
    if not raw.strip(", "):
        return list(get_session().scalars(select(Participant).order_by(Participant.id.desc())))
    if len(codes) > MAX_LINKS or any(not CODE.fullmatch(c) for c in codes):
        abort(400, f"codes= lists 1 to {MAX_LINKS} participant codes, comma-separated")
    try:
        return participants_by_code(get_session(), codes)
    except ConsoleError as error:
        abort(404, str(error))


@bp.get("/links")
@login_required
def links() -> str:
    """Every link of a batch, each with a copy button, and the same list as CSV."""
    rows = link_rows(get_session(), _named_participants())
    return render_template(
        "console/links.html",
        rows=rows,
        batches=[] if request.args.get("codes") else batches(get_session()),
        usable=sum(row["status"] in USABLE for row in rows),
        usable_statuses=USABLE,
        csv_url=url_for("console.links_csv_download", codes=request.args.get("codes", "")),
    )


@bp.get("/links.csv")
@login_required
def links_csv_download() -> Response:
    rows = link_rows(get_session(), _named_participants())
    return Response(
        links_csv(rows),
        mimetype="text/csv",
        headers={"Content-Disposition": "attachment; filename=participant-links.csv"},
    )


@bp.get("/participants/<code>")
@login_required
def participant(code: str) -> str:
    found = _participant(code)
    session = get_session()
    state, status = participant_state(session, found.id), study_status(session, found)
    pilot = is_pilot(session, found)
    actions = session.scalars(
        select(ConsoleAction)
        .where(ConsoleAction.participant_id == found.id)
        .order_by(ConsoleAction.id)
    ).all()
    return render_template(
        "console/participant.html",
        participant=found,
        pilot=pilot,
        link=participant_link(found),
        state=state,
        status=status,
        enrolment=current_enrolment(session, found.id),
        offered=available_actions(state, status, pilot),
        skip_targets=skip_targets(session, found) if status == "in_progress" else [],
        action_labels=ACTION_LABELS,
        actions=actions,
        action_form=forms.ActionForm(),
        withdraw_form=forms.WithdrawForm(),
    )


SESSION_ACTIONS = {
    "pause",
    "resume",
    "abort",
    "mark_pilot",
    "unmark_pilot",
    "skip_stage",
    "reinstate",
}
ACTION_LABELS = {
    "pause": "Pause",
    "resume": "Resume",
    "abort": "Abort",
    "mark_pilot": "Mark pilot",
    "unmark_pilot": "Unmark pilot",
    "skip_stage": "Skip stage",
    "reinstate": "Reinstate",
}


#: What the table's "Selected rows" form applies to every participant ticked.
BULK_ACTIONS = ("pause", "resume", "mark_pilot", "unmark_pilot", "abort")


@bp.post("/bulk")
@login_required
def bulk():  # type: ignore[no-untyped-def]
    """One action on the participants ticked in the table, each audited as if done on its own."""
    action = request.form.get("action", "")
    if action not in BULK_ACTIONS or not forms.ActionForm().validate_on_submit():
        abort(400)
    codes = request.form.getlist("codes")
    if not codes:
        flash("Tick the participants first; nothing was changed.")
        return redirect(url_for("console.index")), 303
    if len(codes) > MAX_LINKS or any(not CODE.fullmatch(code) for code in codes):
        abort(400, f"up to {MAX_LINKS} participant codes")
    try:
        chosen = participants_by_code(get_session(), codes)
    except ConsoleError as error:
        abort(404, str(error))
    done, refused = [], []
    for found in chosen:
        try:
            if action in ("pause", "resume", "abort"):
                change_participant_state(database(), _live(), found, current_user, action)
            else:
                set_pilot(database(), _live(), found, current_user, action == "mark_pilot")
            done.append(found.code)
        except ConsoleError as error:
            refused.append(str(error))
    label = ACTION_LABELS[action].lower()
    flash(
        f"{label}: {len(done)} of {len(chosen)} done"
        + (f"; {'; '.join(refused)}" if refused else "")
    )
    return redirect(url_for("console.index")), 303


@bp.post("/participants/<code>/<action>")
@login_required
def act(code: str, action: str):
    if action not in SESSION_ACTIONS:
        abort(404)
    if not forms.ActionForm().validate_on_submit():
        abort(400)
    found = _participant(code)
    # The live table's buttons come back to the table; the participant page's to itself.
    back = request.form.get("next")
    back = _safe_next(back) if back else url_for("console.participant", code=code)
    try:
        if action in ("mark_pilot", "unmark_pilot"):
            set_pilot(database(), _live(), found, current_user, action == "mark_pilot")
        elif action == "skip_stage":
            skipped = skip_step(database(), _live(), found, current_user, _to_stage())
            flash(f"{code}: skipped {skipped}")
            return redirect(back), 303
        elif action == "reinstate":
            reinstate(database(), _live(), found, current_user)
        else:
            change_participant_state(database(), _live(), found, current_user, action)
    except ConsoleError as error:
        flash(str(error))
        return redirect(back), 303
    flash(f"{code}: {action.replace('_', ' ')} done")
    return redirect(back), 303


def _to_stage() -> int | None:
    """The stage a skip moves the participant to (``to_stage``, 1-based); None: the next step."""
    raw = request.form.get("to_stage", "")
    if not raw:
        return None
    if not (raw.isascii() and raw.isdigit() and len(raw) < 4):
        abort(400, "to_stage is a stage number")
    return int(raw)


@bp.post("/participants/<code>/withdraw")
@login_required
def withdraw_participant(code: str):
    form = forms.WithdrawForm()
    if not form.validate_on_submit():
        abort(400)
    if form.confirm_code.data.strip() != code:
        flash("The code typed does not match; nothing was deleted.")
        return redirect(url_for("console.participant", code=code)), 303
    try:
        counts = withdraw(database(), _live(), code, current_user.username)
    except WithdrawalError as error:
        flash(str(error))
        return redirect(url_for("console.index")), 303
    flash(f"{code} withdrawn: {sum(counts.values())} rows deleted, audit recorded")
    return redirect(url_for("console.index")), 303


@bp.get("/export.zip")
@login_required
def export_zip() -> ResponseReturnValue:
    """The export as a zip: every participant, or one study's (`?study=NAME`)."""
    from hcss.platform.export.archive import export_archive
    from hcss.platform.export.selection import UnknownStudy

    study = request.args.get("study") or None
    try:
        archive, name = export_archive(database(), current_user.username, study)
    except UnknownStudy as error:
        flash(str(error))
        return redirect(url_for("console.index")), 303
    return send_file(archive, mimetype="application/zip", as_attachment=True, download_name=name)

"""Online recruitment: the recruitment site's ids of each participant enrolled by a study link.

Drafted by autogenerate and read by hand against
hcss/platform/models/recruitment.py: one row per participant (unique), and
(study, source, recruitment_id) unique so a returning Prolific/SONA/MTurk id
resumes instead of enrolling twice. The app only ever inserts into it.

Revision ID: 0004_o14_online
Revises: 0004_c8_console
Create Date: 2026-11-26 18:15:37.515427
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0004_o14_online"
down_revision = "0004_c8_console"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "recruitment",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("participant_id", sa.Integer(), nullable=False),
        sa.Column("study", sa.String(length=64), nullable=False),
        sa.Column("source", sa.String(length=16), nullable=False),
        sa.Column("recruitment_id", sa.String(length=128), nullable=True),
        sa.Column("recruiter_study_id", sa.String(length=128), nullable=True),
        sa.Column("recruiter_session_id", sa.String(length=128), nullable=True),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.ForeignKeyConstraint(
            ["participant_id"],
            ["participant.id"],
            name=op.f("fk_recruitment_participant_id_participant"),
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_recruitment")),
        sa.UniqueConstraint("participant_id", name=op.f("uq_recruitment_participant_id")),
        sa.UniqueConstraint(
            "study", "source", "recruitment_id", name="uq_recruitment_identity"
        ),
    )


def downgrade() -> None:
    op.drop_table("recruitment")

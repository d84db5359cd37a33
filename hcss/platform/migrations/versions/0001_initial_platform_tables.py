"""Initial platform tables: participants, trials and everything a live trial records.

Read by hand after autogenerate: every timestamp is naive UTC (the app's
UTCDateTime), JSON columns hold the scenario, parameters, choices and
decision records, and no table is ever updated in place by the app.

Revision ID: 0001
Revises:
Create Date: 2026-11-22 03:19:23.084599
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op



revision = '0001'
down_revision = None
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table('participant',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('code', sa.String(length=32), nullable=False),
    sa.Column('token', sa.String(length=64), nullable=False),
    sa.Column('is_demo', sa.Boolean(), nullable=False),
    sa.Column('is_pilot', sa.Boolean(), nullable=False),
    sa.Column('is_bot', sa.Boolean(), nullable=False),
    sa.Column('created_at', sa.DateTime(), nullable=False),
    sa.PrimaryKeyConstraint('id', name=op.f('pk_participant')),
    sa.UniqueConstraint('code', name=op.f('uq_participant_code'))
    )
    with op.batch_alter_table('participant', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_participant_token'), ['token'], unique=True)

    op.create_table('trial',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('participant_id', sa.Integer(), nullable=False),
    sa.Column('kind', sa.String(length=16), nullable=False),
    sa.Column('model', sa.String(length=4), nullable=False),
    sa.Column('scenario', sa.JSON(), nullable=False),
    sa.Column('scenario_id', sa.String(length=64), nullable=False),
    sa.Column('seed', sa.Integer(), nullable=False),
    sa.Column('first_section', sa.String(length=16), nullable=True),
    sa.Column('params', sa.JSON(), nullable=True),
    sa.Column('time_acceleration', sa.Double(), nullable=False),
    sa.Column('duration_s', sa.Double(), nullable=False),
    sa.Column('started_at', sa.DateTime(), nullable=False),
    sa.Column('deadline', sa.DateTime(), nullable=False),
    sa.Column('created_at', sa.DateTime(), nullable=False),
    sa.ForeignKeyConstraint(['participant_id'], ['participant.id'], name=op.f('fk_trial_participant_id_participant')),
    sa.PrimaryKeyConstraint('id', name=op.f('pk_trial'))
    )
    with op.batch_alter_table('trial', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_trial_participant_id'), ['participant_id'], unique=False)

    op.create_table('command',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('trial_id', sa.Integer(), nullable=False),
    sa.Column('kind', sa.String(length=16), nullable=False),
    sa.Column('collective', sa.Integer(), nullable=True),
    sa.Column('target', sa.Integer(), nullable=True),
    sa.Column('cancel_request_id', sa.Integer(), nullable=True),
    sa.Column('step_applied', sa.Integer(), nullable=False),
    sa.Column('sim_time', sa.Double(), nullable=False),
    sa.Column('support', sa.Double(), nullable=True),
    sa.Column('decision_index', sa.Integer(), nullable=True),
    sa.Column('selections', sa.JSON(), nullable=False),
    sa.Column('created_at', sa.DateTime(), nullable=False),
    sa.ForeignKeyConstraint(['trial_id'], ['trial.id'], name=op.f('fk_command_trial_id_trial')),
    sa.PrimaryKeyConstraint('id', name=op.f('pk_command'))
    )
    with op.batch_alter_table('command', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_command_trial_id'), ['trial_id'], unique=False)

    op.create_table('decision',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('trial_id', sa.Integer(), nullable=False),
    sa.Column('collective', sa.Integer(), nullable=False),
    sa.Column('decision_index', sa.Integer(), nullable=False),
    sa.Column('step', sa.Integer(), nullable=False),
    sa.Column('correct', sa.Boolean(), nullable=True),
    sa.Column('record', sa.JSON(), nullable=False),
    sa.Column('created_at', sa.DateTime(), nullable=False),
    sa.ForeignKeyConstraint(['trial_id'], ['trial.id'], name=op.f('fk_decision_trial_id_trial')),
    sa.PrimaryKeyConstraint('id', name=op.f('pk_decision'))
    )
    with op.batch_alter_table('decision', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_decision_trial_id'), ['trial_id'], unique=False)

    op.create_table('interruption',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('trial_id', sa.Integer(), nullable=False),
    sa.Column('snapshot_step', sa.Integer(), nullable=False),
    sa.Column('resumed_step', sa.Integer(), nullable=False),
    sa.Column('replayed_commands', sa.Integer(), nullable=False),
    sa.Column('state_digest', sa.String(length=128), nullable=False),
    sa.Column('last_seen_at', sa.DateTime(), nullable=True),
    sa.Column('created_at', sa.DateTime(), nullable=False),
    sa.ForeignKeyConstraint(['trial_id'], ['trial.id'], name=op.f('fk_interruption_trial_id_trial')),
    sa.PrimaryKeyConstraint('id', name=op.f('pk_interruption'))
    )
    with op.batch_alter_table('interruption', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_interruption_trial_id'), ['trial_id'], unique=False)

    op.create_table('observation',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('trial_id', sa.Integer(), nullable=False),
    sa.Column('kind', sa.String(length=16), nullable=False),
    sa.Column('collective', sa.Integer(), nullable=True),
    sa.Column('target', sa.Integer(), nullable=True),
    sa.Column('button', sa.String(length=8), nullable=False),
    sa.Column('step', sa.Integer(), nullable=False),
    sa.Column('sim_time', sa.Double(), nullable=False),
    sa.Column('created_at', sa.DateTime(), nullable=False),
    sa.ForeignKeyConstraint(['trial_id'], ['trial.id'], name=op.f('fk_observation_trial_id_trial')),
    sa.PrimaryKeyConstraint('id', name=op.f('pk_observation'))
    )
    with op.batch_alter_table('observation', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_observation_trial_id'), ['trial_id'], unique=False)

    op.create_table('probe',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('trial_id', sa.Integer(), nullable=False),
    sa.Column('probe_index', sa.Integer(), nullable=False),
    sa.Column('level', sa.Integer(), nullable=False),
    sa.Column('question', sa.String(length=200), nullable=False),
    sa.Column('choices', sa.JSON(), nullable=False),
    sa.Column('truth', sa.String(length=16), nullable=True),
    sa.Column('shown_step', sa.Integer(), nullable=False),
    sa.Column('shown_sim_time', sa.Double(), nullable=False),
    sa.Column('timeout_sim_time', sa.Double(), nullable=False),
    sa.Column('created_at', sa.DateTime(), nullable=False),
    sa.ForeignKeyConstraint(['trial_id'], ['trial.id'], name=op.f('fk_probe_trial_id_trial')),
    sa.PrimaryKeyConstraint('id', name=op.f('pk_probe'))
    )
    with op.batch_alter_table('probe', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_probe_trial_id'), ['trial_id'], unique=False)

    op.create_table('request_status_change',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('trial_id', sa.Integer(), nullable=False),
    sa.Column('request_id', sa.Integer(), nullable=False),
    sa.Column('status', sa.String(length=16), nullable=False),
    sa.Column('step', sa.Integer(), nullable=False),
    sa.Column('sim_time', sa.Double(), nullable=False),
    sa.Column('created_at', sa.DateTime(), nullable=False),
    sa.ForeignKeyConstraint(['trial_id'], ['trial.id'], name=op.f('fk_request_status_change_trial_id_trial')),
    sa.PrimaryKeyConstraint('id', name=op.f('pk_request_status_change'))
    )
    with op.batch_alter_table('request_status_change', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_request_status_change_trial_id'), ['trial_id'], unique=False)

    op.create_table('sim_event',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('trial_id', sa.Integer(), nullable=False),
    sa.Column('kind', sa.String(length=32), nullable=False),
    sa.Column('collective', sa.Integer(), nullable=True),
    sa.Column('target', sa.Integer(), nullable=True),
    sa.Column('text', sa.String(length=300), nullable=False),
    sa.Column('sim_time', sa.Double(), nullable=False),
    sa.Column('created_at', sa.DateTime(), nullable=False),
    sa.ForeignKeyConstraint(['trial_id'], ['trial.id'], name=op.f('fk_sim_event_trial_id_trial')),
    sa.PrimaryKeyConstraint('id', name=op.f('pk_sim_event'))
    )
    with op.batch_alter_table('sim_event', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_sim_event_trial_id'), ['trial_id'], unique=False)

    op.create_table('snapshot',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('trial_id', sa.Integer(), nullable=False),
    sa.Column('step', sa.Integer(), nullable=False),
    sa.Column('sim_time', sa.Double(), nullable=False),
    sa.Column('last_command_id', sa.Integer(), nullable=True),
    sa.Column('blob', sa.LargeBinary(), nullable=False),
    sa.Column('created_at', sa.DateTime(), nullable=False),
    sa.ForeignKeyConstraint(['trial_id'], ['trial.id'], name=op.f('fk_snapshot_trial_id_trial')),
    sa.PrimaryKeyConstraint('id', name=op.f('pk_snapshot'))
    )
    with op.batch_alter_table('snapshot', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_snapshot_trial_id'), ['trial_id'], unique=False)

    op.create_table('trial_status_change',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('trial_id', sa.Integer(), nullable=False),
    sa.Column('status', sa.String(length=16), nullable=False),
    sa.Column('reason', sa.String(length=64), nullable=False),
    sa.Column('step', sa.Integer(), nullable=False),
    sa.Column('created_at', sa.DateTime(), nullable=False),
    sa.ForeignKeyConstraint(['trial_id'], ['trial.id'], name=op.f('fk_trial_status_change_trial_id_trial')),
    sa.PrimaryKeyConstraint('id', name=op.f('pk_trial_status_change'))
    )
    with op.batch_alter_table('trial_status_change', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_trial_status_change_trial_id'), ['trial_id'], unique=False)

    op.create_table('command_outcome',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('command_id', sa.Integer(), nullable=False),
    sa.Column('accepted', sa.Boolean(), nullable=False),
    sa.Column('request_id', sa.Integer(), nullable=True),
    sa.Column('reason', sa.String(length=200), nullable=False),
    sa.Column('intervention', sa.Boolean(), nullable=False),
    sa.Column('created_at', sa.DateTime(), nullable=False),
    sa.ForeignKeyConstraint(['command_id'], ['command.id'], name=op.f('fk_command_outcome_command_id_command')),
    sa.PrimaryKeyConstraint('id', name=op.f('pk_command_outcome')),
    sa.UniqueConstraint('command_id', name=op.f('uq_command_outcome_command_id'))
    )
    op.create_table('probe_event',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('probe_id', sa.Integer(), nullable=False),
    sa.Column('kind', sa.String(length=16), nullable=False),
    sa.Column('answer', sa.String(length=16), nullable=True),
    sa.Column('truth', sa.String(length=16), nullable=True),
    sa.Column('correct', sa.Boolean(), nullable=True),
    sa.Column('step', sa.Integer(), nullable=False),
    sa.Column('sim_time', sa.Double(), nullable=False),
    sa.Column('created_at', sa.DateTime(), nullable=False),
    sa.ForeignKeyConstraint(['probe_id'], ['probe.id'], name=op.f('fk_probe_event_probe_id_probe')),
    sa.PrimaryKeyConstraint('id', name=op.f('pk_probe_event'))
    )
    with op.batch_alter_table('probe_event', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_probe_event_probe_id'), ['probe_id'], unique=False)



def downgrade() -> None:
    with op.batch_alter_table('probe_event', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_probe_event_probe_id'))

    op.drop_table('probe_event')
    op.drop_table('command_outcome')
    with op.batch_alter_table('trial_status_change', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_trial_status_change_trial_id'))

    op.drop_table('trial_status_change')
    with op.batch_alter_table('snapshot', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_snapshot_trial_id'))

    op.drop_table('snapshot')
    with op.batch_alter_table('sim_event', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_sim_event_trial_id'))

    op.drop_table('sim_event')
    with op.batch_alter_table('request_status_change', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_request_status_change_trial_id'))

    op.drop_table('request_status_change')
    with op.batch_alter_table('probe', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_probe_trial_id'))

    op.drop_table('probe')
    with op.batch_alter_table('observation', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_observation_trial_id'))

    op.drop_table('observation')
    with op.batch_alter_table('interruption', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_interruption_trial_id'))

    op.drop_table('interruption')
    with op.batch_alter_table('decision', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_decision_trial_id'))

    op.drop_table('decision')
    with op.batch_alter_table('command', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_command_trial_id'))

    op.drop_table('command')
    with op.batch_alter_table('trial', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_trial_participant_id'))

    op.drop_table('trial')
    with op.batch_alter_table('participant', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_participant_token'))

    op.drop_table('participant')

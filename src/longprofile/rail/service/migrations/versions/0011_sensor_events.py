"""declared re-installations and replacements of sensors (the events table of rail settle --events)

Revision ID: 0011
Revises: 0010
Create Date: 2026-12-07
"""
import sqlalchemy as sa
from alembic import op

revision = '0011'
down_revision = '0010'
branch_labels = None
depends_on = None


def upgrade():
    op.create_table('sensor_events',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('site_id', sa.Integer(), nullable=False),
    sa.Column('sensor_id', sa.String(length=64), nullable=False),
    sa.Column('date', sa.String(length=10), nullable=False),
    sa.Column('event', sa.String(length=16), nullable=False),
    sa.Column('new_id', sa.String(length=64), nullable=False),
    sa.ForeignKeyConstraint(['site_id'], ['sites.id'], ),
    sa.PrimaryKeyConstraint('id'),
    sa.UniqueConstraint('site_id', 'sensor_id', 'date', name='uq_event_site_sensor_date')
    )
    with op.batch_alter_table('sensor_events', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_sensor_events_site_id'), ['site_id'], unique=False)


def downgrade():
    with op.batch_alter_table('sensor_events', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_sensor_events_site_id'))
    op.drop_table('sensor_events')

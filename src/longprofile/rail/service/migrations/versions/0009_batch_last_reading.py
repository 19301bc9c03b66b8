"""the newest reading time of a batch (the per-logger no-data alarm on a clock="data" site)

Revision ID: 0009
Revises: 0008
Create Date: 2026-12-07
"""
import sqlalchemy as sa
from alembic import op

revision = '0009'
down_revision = '0008'
branch_labels = None
depends_on = None


def upgrade():
    with op.batch_alter_table('batches', schema=None) as batch_op:
        batch_op.add_column(sa.Column('last_reading_ts', sa.BigInteger(), nullable=True))
    # the batches stored before: the newest of the readings they still hold (a revised reading moved to its batch)
    op.execute("UPDATE batches SET last_reading_ts = (SELECT max(readings.ts) FROM readings "
               "WHERE readings.batch_id = batches.id)")


def downgrade():
    with op.batch_alter_table('batches', schema=None) as batch_op:
        batch_op.drop_column('last_reading_ts')

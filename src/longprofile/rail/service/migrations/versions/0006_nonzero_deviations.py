"""per-day count of non-zero deviations (the outlier test's noise std from the non-zero ones)

Revision ID: 0006
Revises: 0005
Create Date: 2026-12-06
"""
import sqlalchemy as sa
from alembic import op

revision = '0006'
down_revision = '0005'
branch_labels = None
depends_on = None


def upgrade():
    # the cache key of day_cache names the fields, so rows of 0005 are rebuilt from the readings on the next run
    with op.batch_alter_table('day_stats', schema=None) as batch_op:
        batch_op.add_column(sa.Column('n_dev_nonzero', sa.Integer(), nullable=False, server_default='0'))


def downgrade():
    with op.batch_alter_table('day_stats', schema=None) as batch_op:
        batch_op.drop_column('n_dev_nonzero')

"""median lines of the per-day cache (exact medians when the thermal coefficient moves)

Revision ID: 0003
Revises: 0002
Create Date: 2026-12-03
"""
import sqlalchemy as sa
from alembic import op

revision = '0003'
down_revision = '0002'
branch_labels = None
depends_on = None


def upgrade():
    # the cache key of day_cache names the fields, so rows of 0002 are rebuilt from the readings on the next run
    with op.batch_alter_table('day_stats', schema=None) as batch_op:
        batch_op.add_column(sa.Column('n_below_lines', sa.Integer(), nullable=False, server_default='0'))
        batch_op.add_column(sa.Column('median_window_deg_per_c', sa.Float(), nullable=True))
        batch_op.add_column(sa.Column('median_lines', sa.LargeBinary(), nullable=True))


def downgrade():
    with op.batch_alter_table('day_stats', schema=None) as batch_op:
        batch_op.drop_column('median_lines')
        batch_op.drop_column('median_window_deg_per_c')
        batch_op.drop_column('n_below_lines')

"""per-day statistics cache (O(one day) recompute)

Revision ID: 0002
Revises: 0001
Create Date: 2026-12-02
"""
import sqlalchemy as sa
from alembic import op

revision = '0002'
down_revision = '0001'
branch_labels = None
depends_on = None

_FLOATS = ("raw_median_deg", "raw_spread_deg", "noise_used_deg")
_FLOATS3 = ("thermal_slope", "coef_deg_per_c", "median_deg", "median_temp_c", "temp_range_c", "temperature_sum_c")


def upgrade():
    op.create_table('day_cache',
    sa.Column('site_id', sa.Integer(), nullable=False),
    sa.Column('key', sa.String(length=64), nullable=False),
    sa.Column('data_version', sa.BigInteger(), nullable=False),
    sa.Column('updated_ts', sa.BigInteger(), nullable=False),
    sa.ForeignKeyConstraint(['site_id'], ['sites.id'], ),
    sa.PrimaryKeyConstraint('site_id')
    )
    op.create_table('day_stats',
    sa.Column('sensor_pk', sa.Integer(), nullable=False),
    sa.Column('day', sa.Integer(), nullable=False),
    sa.Column('site_id', sa.Integer(), nullable=False),
    sa.Column('n_raw', sa.Integer(), nullable=False),
    *[sa.Column(c, sa.Float(), nullable=True) for c in _FLOATS],
    sa.Column('n_dev_below', sa.Integer(), nullable=False),
    sa.Column('n_dev_at_most', sa.Integer(), nullable=False),
    sa.Column('n_outliers', sa.Integer(), nullable=False),
    sa.Column('n_kept', sa.Integer(), nullable=False),
    *[sa.Column(c, sa.Float(), nullable=True) for c in _FLOATS3],
    sa.Column('n_temperature', sa.Integer(), nullable=False),
    sa.Column('last_ts', sa.BigInteger(), nullable=False),
    sa.ForeignKeyConstraint(['sensor_pk'], ['sensors.id'], ),
    sa.ForeignKeyConstraint(['site_id'], ['sites.id'], ),
    sa.PrimaryKeyConstraint('sensor_pk', 'day')
    )
    with op.batch_alter_table('day_stats', schema=None) as batch_op:
        batch_op.create_index('ix_day_stats_site_day', ['site_id', 'day'], unique=False)


def downgrade():
    with op.batch_alter_table('day_stats', schema=None) as batch_op:
        batch_op.drop_index('ix_day_stats_site_day')
    op.drop_table('day_stats')
    op.drop_table('day_cache')

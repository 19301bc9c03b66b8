"""control surveys of a site and each run's comparison with them

Revision ID: 0004
Revises: 0003
Create Date: 2026-12-03
"""
import sqlalchemy as sa
from alembic import op

revision = '0004'
down_revision = '0003'
branch_labels = None
depends_on = None


def upgrade():
    op.create_table('control_points',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('site_id', sa.Integer(), nullable=False),
    sa.Column('date', sa.String(length=10), nullable=False),
    sa.Column('x_m', sa.Float(), nullable=False),
    sa.Column('z_m', sa.Float(), nullable=False),
    sa.ForeignKeyConstraint(['site_id'], ['sites.id'], ),
    sa.PrimaryKeyConstraint('id'),
    sa.UniqueConstraint('site_id', 'date', 'x_m', name='uq_control_site_date_x')
    )
    with op.batch_alter_table('control_points', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_control_points_site_id'), ['site_id'], unique=False)

    op.create_table('control_comparisons',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('run_id', sa.Integer(), nullable=False),
    sa.Column('date', sa.String(length=10), nullable=False),
    sa.Column('x_m', sa.Float(), nullable=False),
    sa.Column('dz_control_m', sa.Float(), nullable=False),
    sa.Column('dz_estimate_m', sa.Float(), nullable=False),
    sa.Column('std_m', sa.Float(), nullable=False),
    sa.Column('inside_90', sa.Boolean(), nullable=False),
    sa.ForeignKeyConstraint(['run_id'], ['runs.id'], ),
    sa.PrimaryKeyConstraint('id')
    )
    with op.batch_alter_table('control_comparisons', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_control_comparisons_run_id'), ['run_id'], unique=False)


def downgrade():
    with op.batch_alter_table('control_comparisons', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_control_comparisons_run_id'))
    op.drop_table('control_comparisons')
    with op.batch_alter_table('control_points', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_control_points_site_id'))
    op.drop_table('control_points')

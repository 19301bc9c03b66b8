"""indexes of a logger's batches by arrival and by newest reading (the per-logger no-data alarm: one seek per logger)

Revision ID: 0010
Revises: 0009
Create Date: 2026-12-07
"""
from alembic import op

revision = '0010'
down_revision = '0009'
branch_labels = None
depends_on = None


def upgrade():
    op.create_index('ix_batches_logger_received', 'batches', ['logger_id', 'received_ts'])
    op.create_index('ix_batches_logger_last_reading', 'batches', ['logger_id', 'last_reading_ts'])


def downgrade():
    op.drop_index('ix_batches_logger_last_reading', table_name='batches')
    op.drop_index('ix_batches_logger_received', table_name='batches')

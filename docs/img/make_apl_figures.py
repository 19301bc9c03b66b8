"""Generate docs/img figures and numbers for docs/road-apl.md (run: .venv/bin/python docs/img/make_apl_figures.py)."""
import dataclasses
import numpy as np
from matplotlib.figure import Figure
from longprofile.road.apl import *
from longprofile.road import iso8608_profile
from longprofile.report import plot_frequency_response, plot_reconstructions
import pathlib
img=str(pathlib.Path(__file__).resolve().parent)+'/'
# 1. frequency response
fig=plot_frequency_response([apl_model(20,0.05),apl_model(20,0.15),apl_model(20,0.2),apl_model(6,0.05)])
fig.savefig(img+'apl_frequency_response.png',dpi=100)
for k in sorted(TABLE1_CONFIGURATIONS):
    m=apl_model(*k); print('passband', k, [round(v,3) for v in passband(m,tolerance=0.1)], [round(v,3) for v in passband(m,tolerance=0.05)], 'k',m.gain, 'printed k', apl_model(*k,gain_normalisation='as-printed').gain)
# 2. fig 7 / 8 / 9
m=apl_model(20,0.05)
fig=Figure(figsize=(10,8),layout='constrained'); axs=fig.subplots(3,1)
for ax,(p,title) in zip(axs,[(bump_profile(120.0,0.05,width=10,height=0.02),'fig. 7: bump 10 m x 20 mm, 20 m/s, dx 5 cm'),
                             (crenel_profile(120.0,0.05,width=10,height=0.01),'fig. 8: crenel 10 m x 10 mm'),
                             (speed_hump_profile(120.0,0.05,width=5,height=0.05),'fig. 9 (synthetic): speed hump 5 m x 5 cm, 20 m/s')]):
    y=apl_response(p,m); g=double_filter(y,m)
    ax.plot(p.distance,1e3*p.elevation[:,0],'k',label='true'); ax.plot(p.distance,1e3*y.elevation[:,0],label='APL signal'); ax.plot(p.distance,1e3*g.elevation[:,0],label='double filtered')
    ax.set_xlim(30,90); ax.set_title(title); ax.set_ylabel('mm'); ax.legend(fontsize=7)
axs[-1].set_xlabel('distance (m)')
fig.savefig(img+'apl_double_filter_fig7_8.png',dpi=100)
# 3. essais 1-4 (bench at Te = 7.5 ms with the §4.3 model; q/r as in the paper, relative to r = 1)
r43=paper_identified_model('4.3-roots')
rng=np.random.default_rng(0)
N=5000; k=np.arange(N)
cases={}
u1=np.where(((k+250)//500)%2==1,10.0,0.0); cases['essai 1: crenels, q=10, r=1']=(u1,10.0,1.0)
u2=np.zeros(N)
for i in range(5):
    s=250+i*1000; kk=np.arange(500); u2[s:s+500]=10*np.sin(np.pi*kk/500)
cases['essai 2: sine arcs, q=10, r=1']=(u2,10.0,1.0)
u3=rng.normal(0,3,N); cases['essai 3: white noise, q=100, r=1']=(u3,100.0,1.0)
fig=Figure(figsize=(10,11),layout='constrained'); axs=fig.subplots(4,1)
print('essais (time-varying Kalman filter and RTS smoother, §4.3 model as instrument, output noise std 0.14):')
for ax,(name,(u,q,r)) in zip(axs,cases.items()):
    y=apl_filter(r43,u,initial='rest')+rng.normal(0,0.14,N)
    res={}
    for meth in ('filter','smoother'):
        rec=reconstruct_profile(y,dataclasses.replace(r43,dx=1.0),method=meth,q=q,r=r,highpass_wavelength=None,min_length=10.0)
        est=rec.raw_elevation
        res[meth]=est
    t=np.arange(N)*r43.dt
    # 'lissage': remove a quadratic over the record (what the triple differentiator cannot see)
    sl=np.linspace(-1,1,N); V=np.vander(sl,3)
    def det(x): return x-V@np.linalg.lstsq(V,x,rcond=None)[0]
    ax.plot(t,det(u),'k',lw=1,label='true (quadratic removed)')
    for meth,est in res.items():
        e=det(est)-det(u); print(f'  {name}: {meth} RMS error after removing a quadratic = {np.std(e[500:-500]):.3f} (input RMS {np.std(det(u)):.3f})')
        ax.plot(t,det(est),lw=0.8,label=f'{meth}')
    ax.set_title(name); ax.legend(fontsize=7)
    if 'white' in name: ax.set_xlim(t[-200],t[-100])
# essai 4: test track-like: ISO class C road at 6 m/s, 5 cm, 1779 points, eq.(1) 6 m/s model
m6=apl_model(6.0,0.05)
p=iso8608_profile(1778*0.05,0.05,'C',rng=4); u=p.elevation[:,0]-p.elevation[0,0]
y0=apl_response(u,m6); y=y0+rng.normal(0,0.02*y0.std(),u.size)
rec=reconstruct_profile(y,m6,method='smoother',highpass_wavelength=None,min_length=10.0)
recf=reconstruct_profile(y,m6,method='filter',q=rec.q,r=rec.r,highpass_wavelength=None,min_length=10.0)
hp=lambda x: detrend_profile(x,0.05,highpass_wavelength=20.0)
for nm,est in (('smoother',rec.raw_elevation),('filter',recf.raw_elevation)):
    print(f'  essai 4 (synthetic track, 6 m/s, 1779 pts, ML q={rec.q:.3g}, r={rec.r:.3g}): {nm} RMS error after 20 m high-pass = {1e3*np.std((hp(est)-hp(u))[200:-200]):.3f} mm (truth {1e3*np.std(hp(u)):.3f} mm)')
axs[3].plot(p.distance,1e3*hp(u),'k',label='true (20 m high-pass)'); axs[3].plot(p.distance,1e3*hp(recf.raw_elevation),lw=0.8,label='filter'); axs[3].plot(p.distance,1e3*hp(rec.raw_elevation),lw=0.8,label='smoother')
axs[3].set_title('essai 4 (synthetic test track, class C, 6 m/s, dx 5 cm, 1779 points; ML q, r)'); axs[3].legend(fontsize=7); axs[3].set_xlabel('distance (m)')
fig.savefig(img+'apl_essais_1_4.png',dpi=100)

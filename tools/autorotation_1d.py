#!/usr/bin/env python3
"""The vertical autorotation of the X-Cell 60 model, in one dimension: how softly can it land
after an engine failure in a hover, with the best collective schedule of a simple family?

The same disk equations as crates/heli-sim/src/rotor.rs (momentum theory with the Newton
inflow iteration, C_T limited to C_T,max, ground effect k = 1 - (R/4z)^2), the rotor system's
inertia (0.095 kg m^2), the tail rotor's torque scaled with the rotor speed squared, no
forward speed, servo lag 30 ms. The collective holds a sink-rate profile
w(h) = sqrt(w_td^2 + 2 a h) once the sink exceeds it, and otherwise the rotor speed.
Prints the three softest touchdowns found for each starting height (docs/autorotation.md).

    python3 tools/autorotation_1d.py
"""
import math,sys
R=0.775; c=0.058; a=5.5; cd0=0.024; ctmax=0.0055; eta0=0.9; rho=1.225
sig=2*c/(math.pi*R); A=math.pi*R*R; m=8.2; g=9.81; W=m*g; I=0.095
def solve(om,mu,muz,th,l,k=1.0):
    eta=eta0/k
    for i in range(100):
        ct=0.5*a*sig*(th*(1/3+0.5*mu*mu)+0.5*(muz-l))
        off=l-muz; raw=mu*mu+off*off; fl=raw<2.5e-5; root=math.sqrt(max(raw,2.5e-5))
        gg=2*eta*l*root-ct
        dg=2*eta*root+(0 if fl else 2*eta*l*off/root)+0.25*a*sig
        st=-gg/dg; l+= st if abs(st)<1e-4 else 0.6*st
        if abs(st)<1e-12: break
    ct=max(-ctmax,min(ctmax,0.5*a*sig*(th*(1/3+0.5*mu*mu)+0.5*(muz-l))))
    tip=om*R; dyn=rho*tip*tip*A
    cq=ct*(l-muz)+cd0*sig/8*(1+7/3*mu*mu)
    return ct*dyn, cq*dyn*R, l
def gef(h):
    z=max(h+0.585,0.5*R); r=R/(4*z); return max(0.75,1-r*r)
def run(h0, rpm0, law, dt=0.005, verbose=False):
    h=h0; V=0.0; om=rpm0*math.pi/30; l=0.03; col=0.54; t=0; minrpm=rpm0; integ=0
    while h>0 and t<20:
        cmd=law(h,V,om*30/math.pi,t)
        col+= (cmd-col)*min(1,dt/0.03)   # servo lag
        th=col*0.183
        T,Q,l=solve(om,0,V/(om*R),th,l,gef(h))
        Qt=0.7*(om/167)**2
        om+= -(Q+Qt)/I*dt
        V+= (g-T/m)*dt
        h-= V*dt; t+=dt
        minrpm=min(minrpm,om*30/math.pi)
        if verbose and int(t/dt)%20==0: print(f"t={t:.2f} h={h:.2f} V={V:.2f} rpm={om*30/math.pi:.0f} col={col:.2f} T={T:.0f}")
        if om<20: return (V,t,minrpm,'rotor stopped')
    return V,t,minrpm,om*30/math.pi
def mk(decel, wtd, kw, col_lo, col_ff=0.54, wmax=99):
    def law(h,V,rpm,t):
        wt=min(wmax, math.sqrt(wtd*wtd+2*decel*max(h,0)))
        return max(col_lo, min(1.0, col_ff + kw*(V-wt)))
    return law
def combo(target_rpm, decel, kw, k_rpm=0.004, glide=-0.31, col_lo=-0.4, wtd=0.5):
    st={'i':0.0,'cush':False}
    def law(h,V,rpm,t):
        wt=math.sqrt(wtd*wtd+2*decel*max(h,0))
        if V>wt: st['cush']=True
        fr=max(col_lo,min(1.0,glide+k_rpm*(rpm-target_rpm)))
        fs=0.54+kw*(V-wt) if st['cush'] else -9
        return max(fr,fs)
    return law
if __name__ == "__main__":
    print("softest touchdowns (m/s) from a hover, engine failure found at 1500 rpm")
    for h0 in [10, 20, 30, 50]:
        res = []
        for decel in [1, 1.5, 2, 3, 4, 6]:
            for wmax in [3, 4, 5, 6, 8, 99]:
                for col_lo in [-0.4, -0.2, 0.0]:
                    for kw in [0.2, 0.4]:
                        V, t, mr, _ = run(h0, 1500, mk(decel, 0.5, kw, col_lo, wmax=wmax))
                        res.append((round(V, 2), "sink profile", decel, wmax, col_lo, kw, round(mr)))
        for tr in [1300, 1400, 1500, 1600]:
            for decel in [2, 3, 4, 6]:
                for kw in [0.3, 0.6]:
                    V, t, mr, _ = run(h0, 1500, combo(tr, decel, kw))
                    res.append((round(V, 2), "rotor speed, then sink", tr, decel, kw, round(mr)))
        best = sorted(res)[0]
        print(f"{h0:3d} m: {best[0]} m/s ({best[1]}: {best[2:-1]}), lowest rotor speed {best[-1]} rpm")

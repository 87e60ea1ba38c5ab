; mtcal compensation table: Heidenhain KinematicsComp-style COM tables (one per axis; split at BEGIN)
; machine: vmc-golden; measured at: 2026-11-24T08:00:00Z
; sign: the values are the machine's errors (ISO 230-1, tool relative to workpiece); compensation = -error
; units: translations and positions (ADDR) in mm, rotations in degrees
; straightness: deviation from its least-squares line over the measured travel; squareness: angle between the least-squares axis lines (X-Y = 90 deg + EC0Y, X-Z = 90 deg - EB0Z, Y-Z = 90 deg + EA0Z)
; measured travel (the table covers it and nothing else): X [-20, 20] mm; Y [0, 30] mm
; not identifiable, left out: EZX, EBX, ECX, EXY, EZY, EAY, EBY, ECY, EXZ, EYZ, EZZ, EAZ, EBZ, ECZ, EB0Z, EA0Z
; reversal (lost motion) found: none found (b > 0: the axis stops short in the direction of travel; error forward = -b/2, reverse = +b/2; ISO 230-2 B = -b)
; this format does not carry the reversal: set it in the controller's backlash (reversal) compensation, or export format linuxcnc or csv
; thermal coefficients per kelvin: none found
; this format does not carry thermal compensation: set the coefficients in the controller's thermal compensation, or export format csv
; X.COM columns: C1 = EXX, C2 = EYX, C4 = EAX
; Y.COM columns: C2 = EYY
; position errors, for the kinematics table (COORD), degrees:
; C0Y = +0.000716197244
BEGIN X.COM MM
NR                ADDR                C1                C2                C4
0           -20.000000      -0.000200000      +0.000266667    -0.00005729578
1           -10.000000      -0.000100000      -0.000033333    -0.00002864789
2            +0.000000      +0.000000000      -0.000133333    +0.00000000000
3           +10.000000      +0.000100000      -0.000033333    +0.00002864789
4           +20.000000      +0.000200000      +0.000266667    +0.00005729578
[END]
BEGIN Y.COM MM
NR                ADDR                C2
0            +0.000000      +0.000000000
1           +10.000000      -0.000190000
2           +20.000000      -0.000360000
3           +30.000000      -0.000510000
[END]
